"""Which goals a live robot is following, and when one ends: a pure rule, fed poses and commands.

A plain ``goal_pose`` topic (no Nav2 action) says nothing back, so the ``ros`` backend decides from the
robot's pose: a goal is reached within :data:`GOAL_TOLERANCE` metres (and, when a yaw was asked for,
:data:`GOAL_YAW_TOLERANCE` radians); teleoperation or a cancel ends it. Each method returns the
:class:`~relay.fleet.events.NavEvent` to report, or None.
"""

from __future__ import annotations

import math

from ..fleet.events import NavEvent, PoseEvent
from ..fleet.geometry import quaternion_to_yaw, wrap_angle

#: A goal counts as reached within this distance (m) and, when a yaw was given, this angle (rad).
GOAL_TOLERANCE = 0.25
GOAL_YAW_TOLERANCE = 0.2

Goal = tuple[float, float, float | None]


class GoalWatch:
    def __init__(self) -> None:
        self._goals: dict[str, Goal] = {}

    def started(self, robot: str, goal: Goal) -> NavEvent:
        self._goals[robot] = goal
        return NavEvent(robot, True, goal, "started")

    def pose(self, pose: PoseEvent) -> NavEvent | None:
        """A new pose: the goal it reaches, if any, ends."""
        goal = self._goals.get(pose.robot)
        if goal is None:
            return None
        x, y, yaw = goal
        close = math.hypot(pose.x - x, pose.y - y) <= GOAL_TOLERANCE
        heading = quaternion_to_yaw(pose.qx, pose.qy, pose.qz, pose.qw)
        if close and (yaw is None or abs(wrap_angle(heading - yaw)) <= GOAL_YAW_TOLERANCE):
            del self._goals[pose.robot]
            return NavEvent(pose.robot, False, goal, "reached", "goal reached")
        return None

    def ended(self, robot: str, why: str) -> NavEvent | None:
        """The goal was given up (``why``: cancelled, teleoperation took over)."""
        goal = self._goals.pop(robot, None)
        return None if goal is None else NavEvent(robot, False, goal, "cancelled", why)
