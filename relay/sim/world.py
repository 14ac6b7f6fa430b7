"""The simulated fleet's world, without any I/O: robots, their commands, goals, and sensor readings.

Two adapters drive it: the ``sim`` backend (``relay.backends.sim``, asyncio, the relay's default) and
``tools/fake_fleet.py`` (rclpy timers, publishing the same robots over real ROS topics). Both call
``step(dt)`` at ``physics_rate`` and read poses and sensors at their own rates, so both fleets behave alike.

Each robot is a differential-drive base integrated within its limits, with a bumper against the occupancy
grid. Goals are planned on the grid (A* around walls) and followed by pure pursuit; a velocity command
overrides navigation. Like a real base, a robot keeps its last velocity command until told otherwise:
stopping it on silence is the relay's deadman, not the simulator's.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import numpy as np

from ..config import FleetConfig, Robot
from ..twin.facility import load_facility
from .floorplan import demo_facility, rasterise
from .follower import PathFollower
from .hazards import HazardSource, SensorField
from .kinematics import DiffDriveState, DriveLimits, step
from .planner import NoPathError, Planner
from .spill import GrownSpill, grow_sources
from .valve import ValveWheel

logger = logging.getLogger(__name__)

#: Footprint radius of the simulated robots (a TurtleBot3 Waffle is 0.28 x 0.31 m).
ROBOT_RADIUS = 0.2
#: The planner keeps this much clearance so that paths do not graze walls.
PLANNING_RADIUS = 0.3

Outcome = Literal["started", "reached", "failed", "cancelled"]
Goal = tuple[float, float, float | None]
#: Called with (robot, navigating, goal, outcome, message) whenever navigation starts or ends.
NavListener = Callable[[str, bool, Goal | None, Outcome, str], None]

__all__ = ["NoPathError", "SimRobot", "SimWorld", "build_fields"]


@dataclass
class SimRobot:
    spec: Robot
    state: DiffDriveState
    limits: DriveLimits
    rng: np.random.Generator
    command: tuple[float, float] = (0.0, 0.0)
    follower: PathFollower | None = None
    goal: Goal | None = None


#: Units of quantities that cannot be negative: a field read in one of them has a floor at 0.
NON_NEGATIVE_UNITS = frozenset({"ppm", "ppb", "%", "lx", "Pa", "mg/m3", "ug/m3", "µg/m3", "uSv/h", "µSv/h", "Bq/m3"})


def build_fields(config: FleetConfig, scene_hazards: tuple[HazardSource, ...] = ()) -> dict[str, SensorField]:
    """The sensor fields of robots.yaml's ``sim`` section, keyed by kind.

    Hazard sources come from robots.yaml's ``sim.hazards`` when it lists any, else from the scene
    (``sim.world``); baselines and noise from ``sim.fields``.
    """
    hazards = (
        tuple(HazardSource(kind=h.kind, x=h.x, y=h.y, peak=h.peak, sigma=h.sigma) for h in config.sim.hazards)
        or scene_hazards
    )
    fields: dict[str, SensorField] = {}
    kinds = {f.kind for f in config.sim.fields} | {h.kind for h in hazards}
    for kind in sorted(kinds):
        spec = next((f for f in config.sim.fields if f.kind == kind), None)
        sources = tuple(h for h in hazards if h.kind == kind)
        units = {s.unit for r in config.robots for s in r.sensors if s.hazard == kind}
        fields[kind] = SensorField(
            kind=kind,
            baseline=spec.baseline if spec else 0.0,
            noise=spec.noise if spec else 0.0,
            sources=sources,
            minimum=0.0 if units and units <= NON_NEGATIVE_UNITS else None,
        )
    return fields


class SimWorld:
    """Every simulated robot of a fleet config in one occupancy grid. Not thread-safe: one owner drives it."""

    def __init__(self, config: FleetConfig, on_nav: NavListener) -> None:
        """Raises ValueError naming the file when ``sim.world`` cannot be loaded."""
        self.config = config
        scene_hazards: tuple[HazardSource, ...] = ()
        #: The scene's glTF, which the simulated cameras look at (None: the robots are blind).
        self.scene_glb: Path | None = None
        if config.sim.world is not None:
            facility = load_facility(config.sim.world)
            self.grid = facility.grid
            scene_hazards = facility.hazards
            self.scene_glb = facility.glb if facility.glb.is_file() else None
        else:
            # No scene file: the demo facility's floor plan, rasterised here.
            self.grid = rasterise(demo_facility())
        self.planner = Planner(self.grid, PLANNING_RADIUS)
        #: Sensor fields as they were at time 0; :meth:`readings` spreads the spill's gas as the spill grows.
        self.fields = build_fields(config, scene_hazards)
        #: Simulated seconds since the world was built: the sum of ``step``'s dt (tests move it by hand).
        self.time = 0.0
        #: The valve wheel an arm turns to shut a leak (robots.yaml ``sim.valve``), if there is one.
        self.valve = ValveWheel(config.sim.valve) if config.sim.valve is not None else None
        # The scene's spill is the demo facility's decal (scenes/facility.yaml is generated from that floor plan
        # and carries no decals of its own).
        self._spill = next((d for d in demo_facility().decals if d.kind == "spill"), None)
        self._grown_fields: tuple[float, dict[str, SensorField]] = (1.0, self.fields)
        self._on_nav = on_nav
        self.robots: dict[str, SimRobot] = {}
        for index, spec in enumerate(config.robots):
            p = spec.initial_pose
            self.robots[spec.name] = SimRobot(
                spec=spec,
                state=DiffDriveState(p.x, p.y, p.yaw, 0.0, 0.0),
                limits=DriveLimits(max_linear=spec.limits.linear, max_angular=spec.limits.angular),
                rng=np.random.default_rng(1000 + index),
            )
            if not self.grid.is_free(p.x, p.y):
                logger.warning("%s starts at (%.2f, %.2f), inside an obstacle", spec.name, p.x, p.y)
            for sensor in spec.sensors:
                if sensor.hazard not in self.fields:
                    logger.warning(
                        "%s sensor %s: no sim field %r in robots.yaml (sim.fields / sim.hazards); it stays silent",
                        spec.name,
                        sensor.name,
                        sensor.hazard,
                    )

    # -- commands ---------------------------------------------------------------------------------

    def set_velocity(self, robot: str, linear: float, angular: float) -> None:
        sim = self.robots[robot]
        if sim.follower is not None and (linear != 0.0 or angular != 0.0):
            self._end_navigation(sim, "cancelled", "teleoperation took over")
        sim.command = (linear, angular)

    def plan(self, robot: str, x: float, y: float) -> list[tuple[float, float]]:
        """A path from the robot to (x, y) around the walls and the other robots where they stand now; raises
        NoPathError (naming the robot in the way when only a robot blocks it). Safe to call from a worker thread.

        The others are discs of ROBOT_RADIUS, kept PLANNING_RADIUS away like walls: a path passes another robot
        0.5 m centre to centre. Robots that move later are not re-planned around (the sim has no local planner).
        """
        state = self.robots[robot].state
        others = {name: (sim.state.x, sim.state.y) for name, sim in self.robots.items() if name != robot}
        grid = self.grid.with_discs((ox, oy, ROBOT_RADIUS) for ox, oy in others.values())
        try:
            return Planner(grid, PLANNING_RADIUS).plan((state.x, state.y), (x, y))
        except NoPathError as exc:
            try:
                self.planner.plan((state.x, state.y), (x, y))
            except NoPathError:
                raise exc from None  # the walls alone forbid it: their reason
            near = [n for n, (ox, oy) in others.items() if math.hypot(ox - x, oy - y) < ROBOT_RADIUS + PLANNING_RADIUS]
            why = f"the goal is next to {near[0]}" if near else "other robots block every path to it"
            raise NoPathError(f"no path from ({state.x:.2f}, {state.y:.2f}) to ({x:.2f}, {y:.2f}): {why}") from None

    def follow(self, robot: str, path: list[tuple[float, float]], yaw: float | None) -> None:
        sim = self.robots[robot]
        x, y = path[-1]
        sim.follower = PathFollower(path, final_yaw=yaw)
        sim.goal = (x, y, yaw)
        sim.command = (0.0, 0.0)
        self._on_nav(robot, True, sim.goal, "started", "")

    def cancel(self, robot: str) -> None:
        sim = self.robots[robot]
        if sim.follower is not None:
            self._end_navigation(sim, "cancelled", "cancelled")
        sim.command = (0.0, 0.0)

    def place(self, robot: str, x: float, y: float, yaw: float) -> None:
        """Put the robot at (x, y, yaw), stopped, its goal given up (a study task's start state)."""
        self.cancel(robot)
        self.robots[robot].state = DiffDriveState(x, y, yaw, 0.0, 0.0)

    def _end_navigation(self, sim: SimRobot, outcome: Outcome, message: str) -> None:
        goal = sim.goal
        sim.follower = None
        sim.goal = None
        self._on_nav(sim.spec.name, False, goal, outcome, message)

    # -- time -------------------------------------------------------------------------------------

    def spill_at(self, elapsed: float | None = None) -> GrownSpill | None:
        """The spill as it has grown after ``elapsed`` simulated seconds (default: now), or None without one."""
        if self._spill is None:
            return None
        scale = self.config.sim.spill_growth.scale(self.time if elapsed is None else elapsed)
        return GrownSpill(self._spill, scale)

    def fields_now(self) -> dict[str, SensorField]:
        """The sensor fields at :attr:`time`: the spill's gas spread as far as the spill has grown."""
        spill = self.spill_at()
        if spill is None or spill.scale == 1.0:
            return self.fields
        scale, fields = self._grown_fields
        if scale != spill.scale:  # rebuilt when the spill has grown since: at most once a physics step
            fields = {k: replace(f, sources=grow_sources(f.sources, spill)) for k, f in self.fields.items()}
            self._grown_fields = (spill.scale, fields)
        return fields

    def step(self, dt: float) -> None:
        self.time += dt
        for sim in self.robots.values():
            linear, angular = sim.command
            if sim.follower is not None:
                linear, angular, done = sim.follower.command(sim.state, sim.limits)
                if done:
                    self._end_navigation(sim, "reached", "goal reached")
                    linear, angular = 0.0, 0.0
            # The bumper: robots may touch walls but never cross them, whoever drives.
            sim.state = step(sim.state, linear, angular, dt, sim.limits, self.grid, radius=ROBOT_RADIUS)

    def readings(self, robot: str) -> list[tuple[str, float]]:
        """(sensor name, value) for each sensor of the robot that has a field."""
        sim = self.robots[robot]
        fields: Mapping[str, SensorField] = self.fields_now()
        if self.valve is not None:  # a shut valve's leak fades (relay/sim/valve.py)
            fields = self.valve.shut(fields, self.time)
        out = []
        for sensor in sim.spec.sensors:
            field = fields.get(sensor.hazard)
            if field is not None:
                out.append((sensor.name, field.value(sim.state.x, sim.state.y, sim.rng)))
        return out
