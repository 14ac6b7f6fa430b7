"""An arm over real DDS (issue #32): the relay's ros backend reads the arm's sensor_msgs/JointState and sends the
operator's arm twists as what MoveIt Servo takes, geometry_msgs/TwistStamped on its delta_twist_cmds in the arm's
base link, clamped to robots.yaml's arm limits; when the twists stop, the deadman sends a zero one. The robot is a
peer process (tests/ros_peer.py) with the two-joint arm of tests/helpers/arm.py."""

from __future__ import annotations

import asyncio
import math
import os
import sys
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest

from relay.config import load_config, parse_config
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.arm import PLANAR_URDF, jog_up_and_settle, tb3_manipulation
from tests.helpers.ros import start_peer
from tests.wsclient import TestClient

pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'` installs the ROS 2 wheels")

pytestmark = pytest.mark.ros

import geometry_msgs.msg  # noqa: E402, F401
import sensor_msgs.msg  # noqa: E402, F401

FLEET = """
safety: {deadman_timeout: 0.5, offline_after: 2.0}
robots:
  - name: alpha
    pose: odom
    limits: {linear: 0.5, angular: 1.0}
    scan: null
    arm:
      urdf: URDF
      base_link: base_link
      tip_link: tip
      limits: {linear: 0.1, angular: 0.5}
      workspace: {min: [-0.5, -0.5, -0.5], max: [0.6, 0.5, 0.6]}
"""
SERVO = "/alpha/servo_node/delta_twist_cmds"


@pytest.fixture
async def arm_relay(ros_domain: int, tmp_path: Path) -> AsyncIterator[RunningRelay]:
    urdf = tmp_path / "planar.urdf"
    urdf.write_text(PLANAR_URDF)
    running = await start_relay(parse_config(FLEET.replace("URDF", str(urdf)), "fleet.yaml"), "ros")
    try:
        yield running
    finally:
        await running.runner.cleanup()


async def test_arm_twists_reach_moveit_servo_as_twist_stamped_and_the_deadman_zeroes_them(
    arm_relay: RunningRelay, tmp_path: Path
) -> None:
    spec = {
        "poses": [{"kind": "odom", "topic": "/alpha/odom", "x": 0.0, "y": 0.0, "yaw": 0.0, "frame": "odom"}],
        "joint_states": [{"topic": "/alpha/joint_states", "names": ["shoulder", "elbow"], "positions": [0.0, 0.5]}],
        "echo_twist_stamped": [SERVO],
    }
    peer = await start_peer(spec, tmp_path)
    client = await TestClient.open(arm_relay.ws_url)
    try:
        await client.hello()
        joints: dict[str, Any] = await client.wait_for(lambda m: m["identifier"] == "alpha/joints", timeout=20)
        assert joints["names"] == ["shoulder", "elbow"] and joints["positions"] == [0.0, 0.5]
        assert len(joints["points"]) == 4  # the base link, two joints, the tip
        # 20 Hz until DDS has matched the publisher and the peer echoes a twist.
        deadline, echoed = time.monotonic() + 20, None
        while echoed is None and time.monotonic() < deadline:
            await client.send({"identifier": "alpha/arm/twist", "linear": [0.0, 0.0, 1.0], "angular": [0, 0, 0]})
            await asyncio.sleep(0.05)
            echoed = next((line for line in peer.lines if line.get("topic") == SERVO), None)
        assert echoed is not None, "MoveIt Servo's topic never got a twist"
        assert echoed["frame"] == "base_link"
        assert echoed["linear"] == pytest.approx([0.0, 0.0, 0.1])  # clamped to arm.limits.linear
        assert abs(echoed["stamp"] - time.time()) < 5
        # The hand falls silent: within the deadman's timeout (and the ticker's beat) a zero twist follows.
        stopped = time.monotonic()
        await peer.wait_for(lambda line: line.get("topic") == SERVO and line["linear"] == [0.0, 0.0, 0.0], timeout=5)
        assert time.monotonic() - stopped < 0.5 + 0.05 + 1.0  # timeout, beat, slack for a loaded machine
    finally:
        await client.close()
        await peer.stop()


FAKE_FLEET = """
safety: {deadman_timeout: 0.5, offline_after: 2.0}
robots:
  - name: robot3
    pose: odom
    limits: {linear: 0.3, angular: 0.8}
    scan: null
    arm:
      urdf: URDF
      srdf: SRDF
      base_link: base_link
      tip_link: end_effector_link
      gripper_joint: gripper_left_joint
      limits: {linear: 0.1, angular: 0.5}
      workspace: {min: [-0.05, -0.3, 0.0], max: [0.4, 0.3, 0.45]}
"""


async def test_the_fake_fleets_arm_follows_a_hand_over_dds_and_the_twin_shows_its_published_joints(
    ros_domain: int, tmp_path: Path
) -> None:
    """Issue #32 over real DDS: the real TurtleBot3 manipulator as tools/fake_fleet.py runs it (tools/fake_arm.py:
    joint_state_broadcaster's JointState out, MoveIt Servo's TwistStamped in, the simulator's kinematics between). A
    client's arm twists move its gripper up; they stop, and so does the arm (its own deadman); the joints the relay
    gives the twin are the ones published on DDS, within a degree. A named pose or a gripper goal is refused, saying
    why."""
    urdf = tb3_manipulation("turtlebot3_manipulation.urdf")
    srdf = tb3_manipulation("config", "turtlebot3_manipulation.srdf")
    config = tmp_path / "fleet.yaml"
    config.write_text(FAKE_FLEET.replace("URDF", str(urdf)).replace("SRDF", str(srdf)))
    fleet = await asyncio.create_subprocess_exec(
        sys.executable, str(ROOT / "tools" / "fake_fleet.py"), "--config", str(config), "--log-level", "warning",
        stdout=asyncio.subprocess.DEVNULL, env=dict(os.environ),
    )  # fmt: skip
    running = await start_relay(await asyncio.to_thread(load_config, config), "ros")
    peer = await start_peer({"echo_joint_states": ["/robot3/joint_states"]}, tmp_path)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        start, joints = await jog_up_and_settle(client, "robot3")
        assert joints["points"][-1][2] > start + 0.02, (start, joints["points"][-1])
        published = next(line for line in reversed(peer.lines) if line.get("topic") == "/robot3/joint_states")
        assert joints["names"] == published["names"]
        apart = max(abs(a - b) for a, b in zip(joints["positions"], published["positions"], strict=True))
        assert math.degrees(apart) < 1.0, (joints["positions"], published["positions"])
        # Named poses and gripper goals are not sent over DDS: refused, saying why and what does send them.
        for command, package in (({"name": "home"}, "trajectory_msgs"), ({"state": "close"}, "control_msgs")):
            what = "pose" if "name" in command else "gripper"
            refusal = await client.request({"identifier": f"robot3/arm/{what}", **command}, 10)
            assert refusal["code"] == "arm_refused" and package in refusal["message"], refusal
            assert "zenoh backend" in refusal["message"], refusal
    finally:
        await client.close()
        await peer.stop()
        await running.runner.cleanup()
        fleet.terminate()
        await fleet.wait()
