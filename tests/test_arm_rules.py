"""The arm's rules without sockets or ROS, on a two-joint arm whose geometry the tests work out themselves: clamps,
refusals that name the joint, the bound or the link, moving away from a bound allowed, the deadman, the E-STOP latch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from relay.arm.rules import ArmBounds, ArmGate, clamp_twist, step_refusal
from relay.config import Limits, Workspace
from tests.helpers.arm import planar

LIMITS = Limits(linear=0.1, angular=0.5)
EVERYWHERE = Workspace((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))


def tip(shoulder: float, elbow: float) -> tuple[float, float]:
    """(x, z) of the planar arm's tip: a turn about +y by a takes x towards -z."""
    return (
        0.2 * math.cos(shoulder) + 0.2 * math.cos(shoulder + elbow),
        0.2 - 0.2 * math.sin(shoulder) - 0.2 * math.sin(shoulder + elbow),
    )


def in_base_box(x: float, z: float, margin: float = 0.0) -> bool:
    return -0.1 - margin < x < 0.1 + margin and -margin < z < 0.1 + margin


def test_a_twist_within_the_limits_is_untouched() -> None:
    result = clamp_twist((0.05, 0.0, -0.05), (0.0, 0.3, 0.0), LIMITS)
    assert (result.linear, result.angular, result.clamped) == ((0.05, 0.0, -0.05), (0.0, 0.3, 0.0), False)


def test_a_fast_twist_is_scaled_to_the_limit_keeping_its_direction() -> None:
    result = clamp_twist((0.3, 0.4, 0.0), (0.0, 0.0, -2.0), LIMITS)
    assert result.clamped
    assert np.linalg.norm(result.linear) == pytest.approx(LIMITS.linear)
    assert result.linear[0] / result.linear[1] == pytest.approx(0.3 / 0.4)
    assert result.angular == pytest.approx((0.0, 0.0, -LIMITS.angular))


def test_a_non_finite_twist_is_a_zero() -> None:
    result = clamp_twist((math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), LIMITS)
    assert (result.linear, result.angular, result.clamped) == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), True)


def test_a_step_that_takes_the_tip_out_of_the_workspace_is_refused_naming_the_bound() -> None:
    arm, bounds = planar(), ArmBounds(Workspace((-1.0, -1.0, -1.0), (0.37, 1.0, 1.0)), joint_margin=0.1)
    assert tip(0.0, 0.6)[0] < 0.37 < tip(0.0, 0.5)[0]
    reason = step_refusal(arm, (0.0, 0.6), (0.0, 0.5), bounds)
    assert reason is not None
    assert "workspace" in reason and "x" in reason and "max 0.37" in reason
    assert step_refusal(arm, (0.0, 0.6), (0.0, 0.65), bounds) is None  # further in


def test_a_tip_outside_the_workspace_may_come_back() -> None:
    arm, bounds = planar(), ArmBounds(Workspace((-1.0, -1.0, -1.0), (0.37, 1.0, 1.0)), joint_margin=0.1)
    assert tip(0.0, 0.35)[0] < tip(0.0, 0.3)[0]  # both outside, the second nearer
    assert step_refusal(arm, (0.0, 0.3), (0.0, 0.35), bounds) is None
    assert step_refusal(arm, (0.0, 0.35), (0.0, 0.3), bounds) is not None  # but not go further out


@pytest.mark.parametrize(
    ("before", "after", "words"),
    [
        ((-1.35, -1.0), (-1.42, -1.0), ("shoulder", "lower limit -1.500")),  # pointing up, tilting back
        ((0.0, -2.35), (0.0, -2.45), ("elbow", "lower limit -2.500")),  # folding up
        ((-1.0, 2.35), (-1.0, 2.45), ("elbow", "upper limit 2.500")),
    ],
)
def test_a_joint_that_would_come_within_the_margin_of_its_limit_is_refused_naming_it(
    before: tuple[float, float], after: tuple[float, float], words: tuple[str, str]
) -> None:
    reason = step_refusal(planar(), before, after, ArmBounds(EVERYWHERE, joint_margin=0.1))
    assert reason is not None
    assert all(word in reason for word in words), reason


@pytest.mark.parametrize(("before", "after"), [((-1.45, -1.0), (-1.44, -1.0)), ((0.0, -2.45), (0.0, -2.44))])
def test_a_joint_within_the_margin_may_move_away_from_its_limit(
    before: tuple[float, float], after: tuple[float, float]
) -> None:
    assert step_refusal(planar(), before, after, ArmBounds(EVERYWHERE, joint_margin=0.1)) is None


def test_folding_the_arm_into_the_base_is_refused_before_it_touches() -> None:
    arm, bounds = planar(), ArmBounds(EVERYWHERE, joint_margin=0.1)
    q, fold, reason = np.array([0.5, 0.0]), np.array([0.0, 0.01]), None
    while reason is None:
        assert q[1] < 2.4, "never refused"
        reason = step_refusal(arm, q, q + fold, bounds)
        if reason is None:
            q = q + fold
    assert "self-collision" in reason and "base_link" in reason and "fore" in reason
    # Where it stopped, the tip and the forearm are still outside the box (the tests' own geometry).
    elbow = (0.2 * math.cos(0.5), 0.2 - 0.2 * math.sin(0.5))
    end = tip(*q)
    for f in np.linspace(0.0, 1.0, 11):
        assert not in_base_box(elbow[0] + f * (end[0] - elbow[0]), elbow[1] + f * (end[1] - elbow[1]))


def test_an_arm_inside_the_base_box_may_leave_it_but_not_go_deeper() -> None:
    arm, bounds = planar(), ArmBounds(EVERYWHERE, joint_margin=0.1)
    assert in_base_box(*tip(0.5, 2.3))
    assert not in_base_box(*tip(0.5, 1.6), margin=0.01)
    assert step_refusal(arm, (0.5, 2.3), (0.5, 1.6), bounds) is None
    assert step_refusal(arm, (0.5, 2.3), (0.5, 2.35), bounds) is not None


def test_an_arm_without_a_base_box_is_never_refused_for_self_collision() -> None:
    arm = planar()
    bare = type(arm)(arm.base_link, arm.tip_link, arm.joints, arm.tip, arm.gripper, ())
    assert step_refusal(bare, (0.5, 2.3), (0.5, 2.35), ArmBounds(EVERYWHERE, joint_margin=0.1)) is None


def test_the_deadman_asks_for_one_zero_when_the_hand_falls_silent() -> None:
    gate = ArmGate(timeout=0.5)
    assert gate.feed(10.0, moving=True) is None
    assert gate.next_deadline() == pytest.approx(10.5)
    assert gate.tick(10.4) is None
    reason = gate.tick(10.5)
    assert reason is not None and "no hand command" in reason
    assert gate.tick(10.6) is None  # once
    assert gate.next_deadline() is None


def test_a_hand_that_keeps_commanding_or_stopped_needs_no_zero() -> None:
    gate = ArmGate(timeout=0.5)
    for now in (0.0, 0.3, 0.6, 0.9):
        gate.feed(now, moving=True)
        assert gate.tick(now + 0.29) is None
    gate.feed(1.0, moving=False)  # a zero twist: nothing more is due
    assert gate.tick(5.0) is None


def test_the_estop_latch_refuses_every_motion_until_reset() -> None:
    gate = ArmGate(timeout=0.5)
    gate.feed(0.0, moving=True)
    gate.latch()
    assert gate.tick(1.0) is None  # the latch stopped it already
    for now in (1.0, 2.0, 30.0):
        reason = gate.feed(now, moving=True)
        assert reason is not None and "estop" in reason
    assert gate.feed(31.0, moving=False) is None  # a stop always passes
    gate.reset()
    assert gate.feed(32.0, moving=True) is None
