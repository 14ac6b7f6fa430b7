"""The built-in simulated fleet: the default backend, so the main command works with no ROS at all.

Each robot of robots.yaml is a differential-drive base integrated at ``sim.physics_rate`` (>= 50 Hz) within
its limits, with a bumper against the facility's walls. Poses are published at ``sim.pose_rate`` whether the
robot moves or not (as odometry is), sensors at ``sim.sensor_rate`` from the hazard fields of robots.yaml.
Goals are planned on the occupancy grid of the facility (A* around walls, ``relay.sim.planner``) and followed
by pure pursuit; a velocity command overrides navigation. Like a real base, a robot keeps its last velocity
command until told otherwise: stopping it on silence is the relay's deadman, not the simulator's.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from dataclasses import dataclass

import numpy as np

from ..config import FleetConfig, Robot
from ..errors import CommandRejected
from ..events import EventSink, NavEvent, PoseEvent, SensorEvent
from ..geometry import yaw_to_quaternion
from ..occupancy import OccupancyGrid
from ..protocol import ErrorCode
from ..sim.floorplan import demo_facility, rasterise
from ..sim.follower import PathFollower
from ..sim.hazards import HazardSource, SensorField
from ..sim.kinematics import DiffDriveState, DriveLimits, step
from ..sim.planner import NoPathError, Planner
from .base import Backend

logger = logging.getLogger(__name__)

#: Footprint radius of the simulated robots (a TurtleBot3 Waffle is 0.28 x 0.31 m).
ROBOT_RADIUS = 0.2
#: The planner keeps this much clearance so that paths do not graze walls.
PLANNING_RADIUS = 0.3


@dataclass
class _SimRobot:
    spec: Robot
    state: DiffDriveState
    limits: DriveLimits
    rng: np.random.Generator
    command: tuple[float, float] = (0.0, 0.0)
    follower: PathFollower | None = None
    goal: tuple[float, float, float | None] | None = None


def build_fields(config: FleetConfig) -> dict[str, SensorField]:
    """The sensor fields of robots.yaml's ``sim`` section, keyed by kind."""
    fields: dict[str, SensorField] = {}
    kinds = {f.kind for f in config.sim.fields} | {h.kind for h in config.sim.hazards}
    for kind in sorted(kinds):
        spec = next((f for f in config.sim.fields if f.kind == kind), None)
        sources = tuple(
            HazardSource(kind=h.kind, x=h.x, y=h.y, peak=h.peak, sigma=h.sigma)
            for h in config.sim.hazards
            if h.kind == kind
        )
        fields[kind] = SensorField(
            kind=kind,
            baseline=spec.baseline if spec else 0.0,
            noise=spec.noise if spec else 0.0,
            sources=sources,
        )
    return fields


class SimBackend(Backend):
    name = "sim"

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        super().__init__(config, sink)
        self.grid: OccupancyGrid = rasterise(demo_facility())
        self._planner = Planner(self.grid, PLANNING_RADIUS)
        self.fields = build_fields(config)
        self.robots: dict[str, _SimRobot] = {}
        for index, spec in enumerate(config.robots):
            p = spec.initial_pose
            self.robots[spec.name] = _SimRobot(
                spec=spec,
                state=DiffDriveState(p.x, p.y, p.yaw, 0.0, 0.0),
                limits=DriveLimits(
                    max_linear=spec.limits.linear,
                    max_angular=spec.limits.angular,
                ),
                rng=np.random.default_rng(1000 + index),
            )
            if not self.grid.is_free(p.x, p.y):
                logger.warning("%s starts at (%.2f, %.2f), inside an obstacle of the facility", spec.name, p.x, p.y)
        for spec in config.robots:
            for sensor in spec.sensors:
                if sensor.hazard not in self.fields:
                    logger.warning(
                        "%s sensor %s: no sim field %r in robots.yaml (sim.fields / sim.hazards); it stays silent",
                        spec.name,
                        sensor.name,
                        sensor.hazard,
                    )
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name="sim-backend")

    async def stop(self) -> None:
        for name in self.robots:
            await self.stop_robot(name)
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    def map_grid(self) -> OccupancyGrid:
        return self.grid

    # -- commands ---------------------------------------------------------------------------------

    async def send_velocity(self, robot: str, linear: float, angular: float) -> None:
        sim = self.robots[robot]
        if sim.follower is not None and (linear != 0.0 or angular != 0.0):
            self._end_navigation(sim, "cancelled", "teleoperation took over")
        sim.command = (linear, angular)

    async def send_goal(self, robot: str, x: float, y: float, yaw: float | None) -> None:
        sim = self.robots[robot]
        start = (sim.state.x, sim.state.y)
        try:
            # A* in pure Python takes milliseconds to tens of them: keep it off the event loop.
            path = await asyncio.to_thread(self._planner.plan, start, (x, y))
        except NoPathError as exc:
            raise CommandRejected(ErrorCode.NO_PATH, f"{robot}/goal_pose: {exc}") from None
        sim.follower = PathFollower(path, final_yaw=yaw)
        sim.goal = (x, y, yaw)
        sim.command = (0.0, 0.0)
        self.sink(NavEvent(robot, True, sim.goal, "started"))

    async def cancel(self, robot: str) -> None:
        sim = self.robots[robot]
        if sim.follower is not None:
            self._end_navigation(sim, "cancelled", "cancelled")
        sim.command = (0.0, 0.0)

    def _end_navigation(self, sim: _SimRobot, outcome: str, message: str) -> None:
        goal = sim.goal
        sim.follower = None
        sim.goal = None
        self.sink(NavEvent(sim.spec.name, False, goal, outcome, message))  # type: ignore[arg-type]

    # -- the simulation loop ----------------------------------------------------------------------

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        sim_cfg = self.config.sim
        dt = 1.0 / max(sim_cfg.physics_rate, 50.0)
        pose_period = 1.0 / sim_cfg.pose_rate
        sensor_period = 1.0 / sim_cfg.sensor_rate
        now = loop.time()
        next_tick = now
        next_pose = now
        next_sensor = now
        while True:
            for sim in self.robots.values():
                self._advance(sim, dt)
            stamp = time.time()
            now = loop.time()
            if now >= next_pose:
                next_pose = max(next_pose + pose_period, now - pose_period)
                for sim in self.robots.values():
                    self._publish_pose(sim, stamp)
            if now >= next_sensor:
                next_sensor = max(next_sensor + sensor_period, now - sensor_period)
                for sim in self.robots.values():
                    self._publish_sensors(sim, stamp)
            next_tick += dt
            delay = next_tick - loop.time()
            if delay < -0.5:
                # The loop was starved (a debugger, a suspended laptop): resynchronise rather than
                # integrating a burst of catch-up steps.
                next_tick = loop.time()
                delay = 0.0
            await asyncio.sleep(max(0.0, delay))

    def _advance(self, sim: _SimRobot, dt: float) -> None:
        linear, angular = sim.command
        if sim.follower is not None:
            linear, angular, done = sim.follower.command(sim.state, sim.limits)
            if done:
                self._end_navigation(sim, "reached", "goal reached")
                linear, angular = 0.0, 0.0
        # The bumper: robots may touch walls but never cross them, whoever drives.
        sim.state = step(sim.state, linear, angular, dt, sim.limits, self.grid, radius=ROBOT_RADIUS)

    def _publish_pose(self, sim: _SimRobot, stamp: float) -> None:
        qx, qy, qz, qw = yaw_to_quaternion(sim.state.yaw)
        self.sink(PoseEvent(sim.spec.name, stamp, "map", sim.state.x, sim.state.y, 0.0, qx, qy, qz, qw))

    def _publish_sensors(self, sim: _SimRobot, stamp: float) -> None:
        for sensor in sim.spec.sensors:
            field = self.fields.get(sensor.hazard)
            if field is not None:
                value = field.value(sim.state.x, sim.state.y, sim.rng)
                self.sink(SensorEvent(sim.spec.name, sensor.name, value, stamp))
