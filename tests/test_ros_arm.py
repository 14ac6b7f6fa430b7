"""An arm over real DDS (issue #32): the relay's ros backend reads the arm's sensor_msgs/JointState and sends the
operator's arm twists as what MoveIt Servo takes, geometry_msgs/TwistStamped on its delta_twist_cmds in the arm's
base link, clamped to robots.yaml's arm limits; when the twists stop, the deadman sends a zero one. The robot is a
peer process (tests/ros_peer.py) with the two-joint arm of tests/helpers/arm.py."""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest

from relay.config import parse_config
from tests.conftest import RunningRelay, start_relay
from tests.helpers.arm import PLANAR_URDF
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
