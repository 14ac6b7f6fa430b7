"""OpenManipulator-X's kinematics: a twist moves the tip its way within the joints' limits, the Jacobian is the
derivative of forward kinematics, and inverse kinematics finds reachable points and says None to the rest."""

from __future__ import annotations

import numpy as np
import pytest

from relay.arm.kinematics import forward, inverse, jacobian, velocity_step
from relay.arm.model import ArmModel, arm_from_urdf
from tests.helpers.arm import omx

HOME = np.array([0.0, -1.0, 0.7, 0.3])  # the SRDF's "home": the tip ahead of and above the base


def follow(model: ArmModel, q: np.ndarray, linear: tuple[float, float, float], seconds: float) -> np.ndarray:
    """Joint positions after following ``linear`` (m/s) with no turn for ``seconds``, at 50 Hz."""
    for _ in range(round(seconds * 50)):
        q = velocity_step(model, q, linear, (0.0, 0.0, 0.0), 0.02).positions
    return q


def numeric_jacobian(model: ArmModel, q: np.ndarray) -> np.ndarray:
    """The tip position's derivative by each joint, by central differences: what jacobian() must agree with."""
    numeric = np.empty((3, len(q)))
    for i in range(len(q)):
        dq = np.zeros(len(q))
        dq[i] = 1e-6
        numeric[:, i] = (forward(model, q + dq)[:3, 3] - forward(model, q - dq)[:3, 3]) / 2e-6
    return numeric


@pytest.mark.parametrize("direction", [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)])
def test_a_twist_moves_the_tip_in_its_direction(direction: tuple[int, int, int]) -> None:
    model = omx()
    speed = 0.05
    linear = (speed * direction[0], speed * direction[1], speed * direction[2])
    before = forward(model, HOME)[:3, 3]
    after = forward(model, follow(model, HOME, linear, 0.4))[:3, 3]
    moved = after - before
    assert np.dot(moved, direction) == pytest.approx(speed * 0.4, rel=0.1)  # 2 cm, at the asked speed
    assert np.linalg.norm(moved - np.dot(moved, direction) * np.array(direction)) < 0.002  # and straight


def test_a_turn_alone_keeps_the_tip_where_it_is_and_pitches_the_gripper() -> None:
    model = omx()
    q = HOME.copy()
    for _ in range(10):
        q = velocity_step(model, q, (0.0, 0.0, 0.0), (0.0, 0.5, 0.0), 0.02).positions
    before, after = forward(model, HOME), forward(model, q)
    assert np.linalg.norm(after[:3, 3] - before[:3, 3]) < 0.002  # position first: it stays
    # The gripper points along its x axis; a turn about +y tips that axis down (towards -z).
    assert after[2, 0] < before[2, 0] - 0.05


def test_joint_speeds_and_positions_stay_within_the_limits() -> None:
    model = omx()
    step = velocity_step(model, HOME, (50.0, 0.0, -50.0), (0.0, 0.0, 0.0), 0.02)
    assert np.all(np.abs(step.velocities) <= model.velocity + 1e-9)
    q = follow(model, HOME, (0.5, 0.0, 0.0), 3.0)  # far past the arm's reach
    assert np.all(q >= model.lower) and np.all(q <= model.upper)


def test_the_jacobian_is_the_derivative_of_the_tip_position() -> None:
    model = omx()
    q = np.array([0.3, -0.4, 0.5, 0.2])
    assert jacobian(model, q)[:3] == pytest.approx(numeric_jacobian(model, q), abs=1e-6)


def test_inverse_then_forward_comes_back_within_a_millimetre() -> None:
    model = omx()
    rng = np.random.default_rng(32)
    for _ in range(25):
        pose = rng.uniform(model.lower * 0.8, model.upper * 0.8)  # a point the arm reaches: it reached it
        target = forward(model, pose)[:3, 3]
        q = inverse(model, target, start=HOME)
        assert q is not None, f"no solution for {target} (reached at {pose})"
        assert np.all(q >= model.lower) and np.all(q <= model.upper)
        assert np.linalg.norm(forward(model, q)[:3, 3] - target) < 1e-3


@pytest.mark.parametrize("target", [(1.0, 0.0, 0.3), (0.0, 0.0, 1.5), (-0.08, 0.0, -0.5)])
def test_a_point_out_of_reach_has_no_solution(target: tuple[float, float, float]) -> None:
    assert inverse(omx(), target) is None


#: A turning column (continuous, about z), a lift (prismatic, along z) and a tilted forearm: the joint kinds and
#: rotated origins OpenManipulator-X lacks.
LIFT_URDF = """<?xml version="1.0"?>
<robot name="lift">
  <link name="base"/><link name="column"/><link name="carriage"/><link name="forearm"/><link name="hand"/>
  <joint name="turn" type="continuous">
    <parent link="base"/><child link="column"/><origin xyz="0.05 0 0.1"/><axis xyz="0 0 1"/>
    <limit velocity="1.5" effort="1"/>
  </joint>
  <joint name="lift" type="prismatic">
    <parent link="column"/><child link="carriage"/><origin xyz="0 0 0.2" rpy="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.3" velocity="0.2" effort="1"/>
  </joint>
  <joint name="tilt" type="revolute">
    <parent link="carriage"/><child link="forearm"/><origin xyz="0.1 0 0" rpy="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/>
  </joint>
  <joint name="hand_fixed" type="fixed">
    <parent link="forearm"/><child link="hand"/><origin xyz="0.25 0 0"/>
  </joint>
</robot>
"""


def test_continuous_and_prismatic_joints_and_rotated_origins() -> None:
    model = arm_from_urdf(LIFT_URDF, "base", "hand")
    assert [j.kind for j in model.joints] == ["revolute", "prismatic", "revolute"]
    assert (model.lower[0], model.upper[0]) == (-np.inf, np.inf)  # continuous: no bounds
    q = np.array([0.7, 0.1, 0.4])
    assert jacobian(model, q)[:3] == pytest.approx(numeric_jacobian(model, q), abs=1e-6)
    # Lifting moves the hand straight up by as much.
    assert forward(model, q + np.array([0.0, 0.05, 0.0]))[:3, 3] - forward(model, q)[:3, 3] == pytest.approx(
        [0, 0, 0.05]
    )
    target = forward(model, (-2.0, 0.2, -0.5))[:3, 3]
    solution = inverse(model, target)
    assert solution is not None and np.linalg.norm(forward(model, solution)[:3, 3] - target) < 1e-3
    step = velocity_step(model, q, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), 0.1)  # up, faster than the lift goes
    assert abs(step.velocities[1]) <= 0.2 + 1e-9
