"""The simulator's arm (OpenManipulator-X with its SRDF's poses), stepped at 50 Hz by a clock moved by hand: twists
move the tip under the rules, named poses at a bounded speed, the gripper, stop, the deadman and the E-STOP."""

from __future__ import annotations

import numpy as np
import pytest

from relay.arm.kinematics import forward
from relay.arm.named import NAMED_SPEED_SCALE
from relay.arm.rules import ArmBounds
from relay.arm.sim_arm import SimArm
from relay.arm.srdf import load_group_states
from relay.config import Limits, Workspace
from tests.helpers.arm import omx, tb3_manipulation

HOME = (0.0, -1.0, 0.7, 0.3)
WORKSPACE = Workspace((-0.3, -0.35, 0.0), (0.45, 0.35, 0.5))
PERIOD = 0.02  # the simulator's physics rate, 50 Hz


def sim_arm(positions: tuple[float, ...] = HOME, workspace: Workspace = WORKSPACE) -> SimArm:
    poses = load_group_states(tb3_manipulation("config", "turtlebot3_manipulation.srdf"))
    return SimArm(omx(), Limits(0.1, 0.5), ArmBounds(workspace, 0.1), poses, timeout=0.5, positions=positions)


def run(arm: SimArm, start: float, seconds: float) -> tuple[float, list[str]]:
    """Step from ``start`` for ``seconds``; the time reached and every reason the arm stopped."""
    reasons, now = [], start
    for _ in range(round(seconds / PERIOD)):
        now += PERIOD
        reason = arm.step(now)
        if reason is not None:
            reasons.append(reason)
    return now, reasons


def tip(arm: SimArm) -> np.ndarray:
    return forward(arm.model, arm.positions)[:3, 3]


def test_a_twist_moves_the_tip_at_the_clamped_speed_while_the_hand_commands() -> None:
    arm = sim_arm()
    arm.step(0.0)
    before = tip(arm)
    now = 0.0
    for _ in range(5):  # the hand asks for 1 m/s forward every 0.2 s; the limit is 0.1 m/s
        assert arm.servo((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), now) is None
        now, reasons = run(arm, now, 0.2)
        assert reasons == []
    moved = tip(arm) - before
    assert moved[0] == pytest.approx(0.1 * 1.0, rel=0.1)
    assert abs(moved[1]) < 0.003 and abs(moved[2]) < 0.003


def test_the_deadman_stops_the_arm_when_the_hand_falls_silent() -> None:
    arm = sim_arm()
    arm.step(0.0)
    arm.servo((0.0, 0.0, 0.05), (0.0, 0.0, 0.0), 0.0)
    _, reasons = run(arm, 0.0, 1.0)
    assert len(reasons) == 1 and "no hand command" in reasons[0]
    # It moved for the timeout (0.5 s) only.
    assert tip(arm)[2] - forward(arm.model, HOME)[2, 3] == pytest.approx(0.05 * 0.5, abs=0.003)
    assert all(v == 0.0 for v in arm.joint_state().velocity)


def test_a_twist_towards_the_workspaces_edge_stops_there_with_the_reason() -> None:
    # Stretched out ahead (the zero pose: the tip 0.3 m up), with a workspace whose floor is 0.2 m up.
    arm = sim_arm(positions=(0.0, 0.0, 0.0, 0.0), workspace=Workspace((-0.3, -0.35, 0.2), (0.45, 0.35, 0.5)))
    arm.step(0.0)
    now, stopped = 0.0, None
    while stopped is None and now < 10.0:
        stopped = arm.servo((0.0, 0.0, -0.1), (0.0, 0.0, 0.0), now)  # down, towards the box's floor
        now, reasons = run(arm, now, 0.1)
        stopped = stopped or (reasons[0] if reasons else None)
    assert stopped is not None and "z" in stopped and "min 0.2" in stopped
    assert 0.2 <= tip(arm)[2] < 0.21
    held = arm.positions
    now, later = run(arm, now, 1.0)
    assert later == []  # stopped: nothing more to say (no deadman after it)
    assert arm.positions == pytest.approx(held)
    assert arm.servo((0.0, 0.0, 0.05), (0.0, 0.0, 0.0), now) is None  # back up is allowed


def test_stop_is_zero_velocity_at_once() -> None:
    arm = sim_arm()
    arm.step(0.0)
    arm.servo((0.05, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0)
    run(arm, 0.0, 0.1)
    assert any(v != 0.0 for v in arm.joint_state().velocity)
    arm.stop()
    held = arm.positions
    assert all(v == 0.0 for v in arm.joint_state().velocity)
    run(arm, 0.1, 0.2)
    assert arm.positions == pytest.approx(held)


def test_home_is_reached_at_a_bounded_joint_speed() -> None:
    arm = sim_arm(positions=(0.5, -0.3, 0.3, 0.0))
    arm.step(0.0)
    assert arm.named("home") is None
    speed = arm.model.velocity * NAMED_SPEED_SCALE
    slowest = float(np.max(np.abs(np.array(HOME) - arm.positions) / speed))
    now, reasons = 0.0, list[str]()
    while not np.allclose(arm.positions, HOME) and now < 10.0:
        before = arm.positions
        now, reasons = run(arm, now, PERIOD)
        assert np.all(np.abs(arm.positions - before) <= speed * PERIOD + 1e-9)
        assert reasons == []
    assert arm.positions == pytest.approx(HOME)
    assert now >= slowest - 1e-9


def test_a_pose_the_srdf_lacks_is_refused_naming_those_it_has() -> None:
    reason = sim_arm().named("stow")
    assert reason is not None and "stow" in reason and "home" in reason


def test_the_gripper_opens_and_closes_within_its_limits() -> None:
    arm = sim_arm()
    arm.step(0.0)
    gripper = arm.model.gripper
    assert gripper is not None
    states = load_group_states(tb3_manipulation("config", "turtlebot3_manipulation.srdf"))["gripper"]
    for command, expected in (("open", states["open"][gripper.name]), ("close", states["close"][gripper.name])):
        assert arm.gripper(command) is None
        run(arm, 0.0, 1.0)
        state = arm.joint_state()
        assert state.position[state.name.index(gripper.name)] == pytest.approx(expected)
        assert state.position[state.name.index("gripper_right_joint")] == pytest.approx(expected)  # the mimic
    assert arm.gripper(1.0) is None  # far past the joint's upper limit
    run(arm, 0.0, 1.0)
    assert arm.joint_state().position[4] == pytest.approx(gripper.upper)


def test_the_joint_state_carries_the_arm_then_the_gripper() -> None:
    state = sim_arm().joint_state()
    assert state.name == ("joint1", "joint2", "joint3", "joint4", "gripper_left_joint", "gripper_right_joint")
    assert state.position[:4] == pytest.approx(HOME)
    assert len(state.velocity) == len(state.position) == len(state.name)


def test_an_estop_refuses_every_arm_motion_until_reset() -> None:
    arm = sim_arm()
    arm.step(0.0)
    arm.servo((0.05, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0)
    arm.estop()
    held = arm.positions
    for refused in (arm.servo((0.05, 0.0, 0.0), (0.0, 0.0, 0.0), 0.1), arm.named("home"), arm.gripper("open")):
        assert refused is not None and "estop" in refused
    run(arm, 0.0, 0.5)
    assert arm.positions == pytest.approx(held)
    arm.reset_estop()
    assert arm.servo((0.05, 0.0, 0.0), (0.0, 0.0, 0.0), 0.6) is None


def test_a_named_pose_outside_the_rules_is_refused_with_the_rules_reason() -> None:
    # The zero pose's tip is 0.2955 m up, home's 0.2935 m: with the workspace's floor at 0.295 m between them,
    # going home would take the tip out of it.
    arm = sim_arm(positions=(0.0, 0.0, 0.0, 0.0), workspace=Workspace((-0.3, -0.35, 0.295), (0.45, 0.35, 0.5)))
    reason = arm.named("home")
    assert reason is not None and reason.startswith("home: the tip would leave the workspace") and "z" in reason
    assert sim_arm(positions=(0.0, 0.0, 0.0, 0.0)).named("home") is None
