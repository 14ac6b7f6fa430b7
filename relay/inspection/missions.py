"""Missions as files and requests: their steps, who does them, and whether every step can be reached.

A mission file (``missions/*.yaml``)::

    name: Demo inspection
    targets: [spill, panels, leak]      # for the fleet: each target to the nearest free robot
    # or, per robot:
    robots:
      - robot: robot1
        steps: [{inspect: spill}, {goto: {x: 3.0, y: 1.5, yaw: 1.57}}, {dwell: 2}, {capture: spill}]

``inspect`` goes to the target's standoff pose (relay.inspection.targets) facing it and captures; ``goto`` goes
to a pose; ``capture`` takes the camera image and the readings where the robot is; ``dwell`` waits.

**Fleet assignment (nearest first):** repeatedly, of all (free robot, unassigned target) pairs, the closest in
straight-line distance is assigned, the robot then counts as standing at that target; every target goes to some
robot, so a fleet of n robots takes about 1/n of the targets each. Robots that are offline, estopped, on a mission
already, or held by another operator are not free.

Before a mission starts every step is checked: unknown targets, poses off the map, and (with a map) a path from
each stop to the next planned with the relay's planner; a problem refuses the whole mission with a message naming
the step, so no robot moves on a half-checked mission. Pure, except that planning takes a while (run it in a
worker). Tested in tests/test_missions.py.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from yaml.nodes import Node

from ..config.reader import _Reader
from ..errors import ConfigError
from ..fleet.occupancy import OccupancyGrid
from ..sim.planner import NoPathError, Planner
from .records import Step
from .targets import TARGET_ID, standoff

MAX_STEPS = 200


class MissionError(ValueError):
    """A mission that cannot start; the message names the file or request, the step and why."""


@dataclass(frozen=True)
class MissionPlan:
    """What a mission asks of the fleet: steps per robot (``robots``), or targets for the fleet (``targets``)."""

    name: str
    robots: tuple[tuple[str, tuple[Step, ...]], ...] = ()
    targets: tuple[str, ...] = ()


def load_mission(path: str | Path) -> MissionPlan:
    source = Path(path)
    try:
        text = source.read_text(encoding="utf-8")
        root = yaml.compose(text)
    except OSError as exc:
        raise MissionError(f"{source}: cannot read the mission file: {exc.strerror or exc}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise MissionError(f"{source}: not a YAML mission file: {exc}") from None
    if root is None:
        raise MissionError(f"{source}: the mission file is empty")
    try:
        return parse_mission(_Reader(str(source)), root, source.stem)
    except ConfigError as exc:
        raise MissionError(str(exc)) from None


def parse_mission(reader: _Reader, root: Node, default_name: str) -> MissionPlan:
    top = reader.mapping(root, "", ("name", "targets", "robots"))
    name = reader.get(top, "name", "", reader.string, default_name)
    if ("targets" in top) == ("robots" in top):
        raise reader.fail(root, "", "give either targets (for the fleet) or robots (steps per robot)")
    if "targets" in top:
        targets = tuple(reader.string(n, f"targets[{i}]") for i, n in reader.sequence(top["targets"], "targets"))
        if not targets:
            raise reader.fail(top["targets"], "targets", "is empty")
        return MissionPlan(name, targets=targets)
    robots = []
    for i, node in reader.sequence(top["robots"], "robots"):
        r = reader.mapping(node, f"robots[{i}]", ("robot", "steps"), required=("robot", "steps"))
        robot = reader.string(r["robot"], f"robots[{i}].robot")
        steps = tuple(_step(reader, s, f"robots[{i}].steps[{j}]") for j, s in reader.sequence(r["steps"], "steps"))
        if not steps or len(steps) > MAX_STEPS:
            raise reader.fail(r["steps"], f"robots[{i}].steps", f"expected 1 to {MAX_STEPS} steps")
        robots.append((robot, steps))
    return MissionPlan(name, robots=tuple(robots))


def _step(reader: _Reader, node: Node, path: str) -> Step:
    f = reader.mapping(node, path, ("inspect", "goto", "capture", "dwell"))
    if len(f) != 1:
        raise reader.fail(node, path, "a step is one of inspect, goto, capture, dwell")
    ((kind, value),) = f.items()
    if kind == "inspect":
        return Step("inspect", target=reader.string(value, f"{path}.inspect"))
    if kind == "capture":
        target = reader.value(value)
        return Step("capture", target=None if target is None else reader.string(value, f"{path}.capture"))
    if kind == "dwell":
        seconds = reader.number(value, f"{path}.dwell", positive=True)
        if seconds > 3600:
            raise reader.fail(value, f"{path}.dwell", "at most 3600 s")
        return Step("dwell", seconds=seconds)
    g = reader.mapping(value, f"{path}.goto", ("x", "y", "yaw"), required=("x", "y"))
    yaw = reader.optional_number(g.get("yaw"), f"{path}.goto.yaw")
    return Step("goto", x=reader.number(g["x"], f"{path}.goto.x"), y=reader.number(g["y"], f"{path}.goto.y"), yaw=yaw)


def steps_from_wire(raw: Any, where: str) -> tuple[Step, ...]:
    """Steps as a client sends them: the file's form, in JSON (``[{"inspect": "spill"}, {"dwell": 2}]``)."""
    if not isinstance(raw, list) or not 1 <= len(raw) <= MAX_STEPS:
        raise MissionError(f"{where}: steps must be a list of 1 to {MAX_STEPS} steps")
    steps = []
    for i, item in enumerate(raw):
        at = f"{where}: steps[{i}]"
        if not isinstance(item, dict) or len(item) != 1:
            raise MissionError(
                f"{at}: a step is one of {{inspect: id}}, {{goto: {{x, y, yaw}}}}, {{capture: id}}, {{dwell: s}}"
            )
        ((kind, value),) = item.items()
        if kind in ("inspect", "capture") and (
            (isinstance(value, str) and TARGET_ID.match(value)) or (kind == "capture" and value is None)
        ):
            steps.append(Step(kind, target=value))
        elif kind == "dwell" and _finite(value) and 0 < value <= 3600:
            steps.append(Step("dwell", seconds=float(value)))
        elif (
            kind == "goto"
            and isinstance(value, dict)
            and _finite(value.get("x"))
            and _finite(value.get("y"))
            and (value.get("yaw") is None or _finite(value.get("yaw")))
        ):
            yaw = value.get("yaw")
            steps.append(
                Step("goto", x=float(value["x"]), y=float(value["y"]), yaw=None if yaw is None else float(yaw))
            )
        else:
            raise MissionError(f"{at}: {kind!r} with {str(value)[:60]!r} is not a valid step")
    return tuple(steps)


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value) and abs(value) < 1e6


def assign(
    targets: Sequence[str], positions: Mapping[str, tuple[float, float]], where: Mapping[str, Any]
) -> dict[str, list[str]]:
    """Targets to free robots, nearest first (module docstring). ``positions``: free robots' (x, y);
    ``where``: target id -> object with x, y.

    Round by round, each robot takes one target: of the robots without one this round, the one nearest to a
    target it could take goes first and then stands there. Nearest targets come from a k-d tree (scipy), queried
    again only for the robot that moved and those whose nearest was just taken: n log n, where the pairwise search
    it replaces was quadratic (a 6000-placemark KMZ held the loop, and another operator's estop, for 9.8 s).
    """
    from scipy.spatial import cKDTree

    if not positions:
        raise MissionError("no robot is free for this mission (online, not estopped, not on a mission or held)")
    plan: dict[str, list[str]] = {robot: [] for robot in positions}
    if not targets:
        return {}
    points = np.array([(where[t].x, where[t].y) for t in targets], dtype=float)
    tree = cKDTree(points)
    taken = np.zeros(len(targets), dtype=bool)
    at = {robot: (float(x), float(y)) for robot, (x, y) in positions.items()}

    def nearest(robot: str) -> tuple[float, int]:
        k = 4
        while True:
            distances, indices = tree.query(at[robot], k=min(k, len(targets)))
            for distance, index in zip(np.atleast_1d(distances), np.atleast_1d(indices), strict=True):
                if not taken[index]:
                    return float(distance), int(index)
            k *= 4  # the neighbourhood is used up: look further (each target is taken once, so this ends)

    left = len(targets)
    while left:
        best = {robot: nearest(robot) for robot in positions}  # this round's robots, each with its nearest
        while best and left:
            robot = min(best, key=lambda r: (best[r][0], r, targets[best[r][1]]))
            _, index = best.pop(robot)
            taken[index] = True
            left -= 1
            plan[robot].append(targets[index])
            at[robot] = (float(points[index][0]), float(points[index][1]))
            for other, (_, other_index) in best.items():
                if other_index == index and left:
                    best[other] = nearest(other)
    return {robot: ts for robot, ts in plan.items() if ts}


@dataclass(frozen=True)
class Waypoint:
    """Where a step sends the robot (None for steps that do not move it)."""

    step: int
    x: float
    y: float
    yaw: float | None


def resolve(
    robot: str,
    steps: Sequence[Step],
    targets: Mapping[str, Any],
    start: tuple[float, float],
    grid: OccupancyGrid | None,
    planner: Planner | None,
) -> list[Waypoint | None]:
    """Each step's waypoint, checked: unknown targets, poses off the map or in a wall, unreachable stops."""
    out: list[Waypoint | None] = []
    here = start
    for i, step in enumerate(steps):
        what = f"{robot}: step {i + 1} ({step.kind}{f' {step.target}' if step.target else ''})"
        if step.target is not None and step.target not in targets:
            known = ", ".join(sorted(targets)) or "none"
            raise MissionError(f"{what}: unknown target {step.target!r}; the targets are {known}")
        if step.kind == "inspect":
            try:
                x, y, yaw = standoff(targets[step.target or ""], grid, here)
            except ValueError as exc:
                raise MissionError(f"{what}: {exc}") from None
            point: Waypoint | None = Waypoint(i, x, y, yaw)
        elif step.kind == "goto":
            assert step.x is not None and step.y is not None
            if grid is not None and not grid.in_bounds(step.x, step.y):
                raise MissionError(f"{what}: ({step.x:g}, {step.y:g}) is outside the map")
            point = Waypoint(i, step.x, step.y, step.yaw)
        else:
            point = None
        if point is not None and planner is not None:
            try:
                planner.plan(here, (point.x, point.y))
            except NoPathError as exc:
                raise MissionError(f"{what}: no path from ({here[0]:g}, {here[1]:g}): {exc}") from None
        if point is not None:
            here = (point.x, point.y)
        out.append(point)
    return out
