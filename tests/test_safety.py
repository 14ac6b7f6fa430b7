"""Safety rules without I/O: clamps, goal bounds and the deadman's timing (time is injected)."""

from __future__ import annotations

import numpy as np
import pytest

from relay.config import Limits
from relay.control.safety import GOAL_CLEARANCE, Deadman, check_goal, check_goal_clear, clamp_velocity
from relay.errors import CommandRejected
from relay.fleet.occupancy import OccupancyGrid

LIMITS = Limits(linear=0.5, angular=1.0)


@pytest.mark.parametrize(
    ("linear", "angular", "expected", "clamped"),
    [
        (0.2, -0.3, (0.2, -0.3), False),
        (5.0, 0.0, (0.5, 0.0), True),
        (-5.0, -9.0, (-0.5, -1.0), True),
        (0.5, 1.0, (0.5, 1.0), False),
    ],
)
def test_clamp(linear: float, angular: float, expected: tuple[float, float], clamped: bool) -> None:
    result = clamp_velocity(linear, angular, LIMITS)
    assert (result.linear, result.angular) == expected
    assert result.clamped is clamped


def test_goal_bounds() -> None:
    grid = OccupancyGrid(origin_x=-1.0, origin_y=-2.0, resolution=0.5, occupied=np.zeros((8, 4), dtype=bool))
    check_goal("r", 0.5, 1.0, grid)
    check_goal("r", 5.0, 5.0, None)  # no map known: only finiteness applies
    with pytest.raises(CommandRejected) as info:
        check_goal("r", 1.5, 0.0, grid)
    assert info.value.code == "out_of_bounds" and "x -1.00..1.00" in info.value.message
    with pytest.raises(CommandRejected):
        check_goal("r", float("nan"), 0.0, None)


def test_a_goal_keeps_clear_of_other_robots_not_of_its_own() -> None:
    others = {"robot1": (3.0, 1.5), "robot2": (9.0, 1.5)}
    check_goal_clear("robot1", 3.0, 1.6, others)  # next to itself: fine
    check_goal_clear("robot1", 9.0, 1.5 + GOAL_CLEARANCE + 1e-6, others)
    with pytest.raises(CommandRejected) as info:
        check_goal_clear("robot1", 9.0, 1.5 + GOAL_CLEARANCE - 1e-6, others)
    assert info.value.code == "occupied"
    assert info.value.message == (
        "robot1/goal_pose: (9.00, 2.10) is 0.60 m from robot2; a goal keeps 0.6 m from other robots"
    )


def test_deadman_expires_after_timeout() -> None:
    deadman = Deadman(0.5)
    deadman.feed("robot1", "a", now=10.0)
    deadman.feed("robot1", "a", now=10.3)
    assert deadman.expired(10.7) == []
    assert deadman.next_deadline() == pytest.approx(10.8)
    assert deadman.expired(10.8) == ["robot1"]
    assert deadman.controller("robot1") is None
    assert deadman.expired(20.0) == []


def test_deadman_release_on_disconnect_and_handover() -> None:
    deadman = Deadman(0.5)
    deadman.feed("robot1", "a", now=0.0)
    deadman.feed("robot2", "a", now=0.0)
    assert deadman.feed("robot3", "b", now=0.0) is None
    assert deadman.feed("robot3", "a", now=0.1) == "b"  # control changed hands
    assert sorted(deadman.release_client("a")) == ["robot1", "robot2", "robot3"]
    assert deadman.release_client("b") == []


def test_a_live_goal_ends_when_reached_facing_its_yaw_or_given_up() -> None:
    from relay.backends.goal_watch import GOAL_TOLERANCE, GoalWatch
    from relay.fleet.events import PoseEvent
    from relay.fleet.geometry import yaw_to_quaternion

    def pose(x: float, y: float, yaw: float) -> PoseEvent:
        qx, qy, qz, qw = yaw_to_quaternion(yaw)
        return PoseEvent("robot1", 1.0, "map", x, y, 0.0, qx, qy, qz, qw)

    watch = GoalWatch()
    assert watch.started("robot1", (3.0, 6.0, 1.57)).outcome == "started"
    assert watch.pose(pose(3.0, 6.0 - 2 * GOAL_TOLERANCE, 1.57)) is None, "not there yet"
    assert watch.pose(pose(3.0, 6.0, 0.0)) is None, "there, but facing the wrong way"
    reached = watch.pose(pose(3.0 + GOAL_TOLERANCE / 2, 6.0, 1.5))
    assert reached is not None and reached.outcome == "reached" and reached.goal == (3.0, 6.0, 1.57)
    assert watch.pose(pose(3.0, 6.0, 1.57)) is None, "a goal ends once"
    watch.started("robot1", (9.0, 6.0, None))
    ended = watch.ended("robot1", "teleoperation took over")
    assert ended is not None and ended.outcome == "cancelled" and ended.message == "teleoperation took over"
    assert watch.ended("robot1", "cancelled") is None
