"""A study's pure rules, time and state passed in: whether a task's success holds, and near-collisions (a robot's
edge within 0.2 m of a wall or of another robot's edge)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Final

from .model import FindingAtTarget, GoalReached, RobotInRegion, Success

#: A robot this close (m) to a wall or to another robot, edge to edge, is a near-collision (issue #34's measure).
NEAR_M: Final = 0.2

#: What a robot comes close to when it is not another robot.
WALL: Final = "wall"
#: Clearance from a point to the nearest wall (m), capped at the limit asked: OccupancyGrid.clearance.
Clearance = Callable[[float, float, float], float]


def inside(x: float, y: float, polygon: Sequence[tuple[float, float]]) -> bool:
    """Whether (x, y) is inside the polygon (even-odd rule; a point on an edge may fall either way)."""
    hit = False
    n = len(polygon)
    for i in range(n):
        (x1, y1), (x2, y2) = polygon[i], polygon[(i + 1) % n]
        if (y1 > y) != (y2 > y) and x < x1 + (y - y1) * (x2 - x1) / (y2 - y1):
            hit = not hit
    return hit


def succeeded(
    success: Success,
    poses: Mapping[str, tuple[float, float]],
    findings: frozenset[str],
    goals_reached: frozenset[str],
    near_collisions: int,
) -> bool:
    """Whether the task's success holds now: ``findings`` the targets marked in the task, ``goals_reached`` the
    robots that reached a goal in it."""
    if isinstance(success, RobotInRegion):
        pose = poses.get(success.robot)
        return pose is not None and inside(pose[0], pose[1], success.region)
    if isinstance(success, FindingAtTarget):
        return success.target in findings
    assert isinstance(success, GoalReached)
    return success.robot in goals_reached and not (success.without_collision and near_collisions > 0)


def contacts(
    poses: Mapping[str, tuple[float, float]], radii: Mapping[str, float], clearance: Clearance | None
) -> frozenset[tuple[str, str]]:
    """The near-collisions now: (robot, "wall") for a robot within NEAR_M of a wall, (a, b) for two robots within
    NEAR_M of each other, edge to edge. Two robots close together are one near-collision, not two."""
    close: set[tuple[str, str]] = set()
    names = sorted(poses)
    for i, a in enumerate(names):
        ax, ay = poses[a]
        ra = radii.get(a, 0.0)
        if clearance is not None and clearance(ax, ay, ra + NEAR_M) < ra + NEAR_M:
            close.add((a, WALL))
        for b in names[i + 1 :]:
            bx, by = poses[b]
            if math.hypot(ax - bx, ay - by) - ra - radii.get(b, 0.0) < NEAR_M:
                close.add((a, b))
    return frozenset(close)
