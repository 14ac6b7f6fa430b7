"""Arms for the arm's tests: OpenManipulator-X on the TurtleBot3 (the shared data) and a two-joint arm in a plane."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from relay.arm.model import ArmModel, arm_from_urdf, load_arm
from tests.conftest import SHARED_DATA
from tests.helpers.waiting import wait_until
from tests.wsclient import TestClient

#: ROBOTIS's turtlebot3_manipulation_description, expanded from its xacro (its PROVENANCE.txt says how).
TB3_MANIPULATION = SHARED_DATA / "robot" / "turtlebot3_manipulation_description"


def tb3_manipulation(*parts: str) -> Path:
    """A file of the TurtleBot3 with OpenManipulator-X; skips the test, naming the folder, when it is absent."""
    path = TB3_MANIPULATION.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"needs ../shared/data/robot/turtlebot3_manipulation_description (no {path})")
    return path


def omx() -> ArmModel:
    """OpenManipulator-X as MoveIt Servo sees it: base_link to end_effector_link, gripper_left_joint apart."""
    urdf = tb3_manipulation("turtlebot3_manipulation.urdf")
    return load_arm(urdf, "base_link", "end_effector_link", "gripper_left_joint")


#: Two joints turning about y, in the x-z plane: a shoulder 0.2 m above base_link's origin, two 0.2 m links. At
#: zero the tip is at (0.4, 0, 0.2); a positive turn about +y lowers it. base_link's box spans x and y -0.1..0.1,
#: z 0..0.1.
PLANAR_URDF = """<?xml version="1.0"?>
<robot name="planar">
  <link name="base_link">
    <collision><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></collision>
  </link>
  <link name="upper"/><link name="fore"/><link name="tip"/>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="upper"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" velocity="2" effort="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper"/><child link="fore"/><origin xyz="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" velocity="2" effort="1"/>
  </joint>
  <joint name="wrist" type="fixed">
    <parent link="fore"/><child link="tip"/><origin xyz="0.2 0 0"/>
  </joint>
</robot>
"""


def planar() -> ArmModel:
    return arm_from_urdf(PLANAR_URDF, "base_link", "tip")


def joint_states(client: TestClient, robot: str) -> list[dict[str, Any]]:
    """The ``<robot>/joints`` messages the client got, oldest first."""
    return [m for _, m in client.messages if m.get("identifier") == f"{robot}/joints"]


async def jog_up_and_settle(client: TestClient, robot: str, seconds: float = 1.5) -> tuple[float, dict[str, Any]]:
    """Move ``robot``'s gripper up at 5 cm/s for ``seconds``, 20 twists a second as the page sends them, then fall
    silent until the arm stands still (a second of its joint states unchanged: its deadman stopped it). The tip's
    height before, and the joints once still."""
    first = await client.wait_for(lambda m: m["identifier"] == f"{robot}/joints", timeout=30)
    for _ in range(round(seconds * 20)):
        await client.send({"identifier": f"{robot}/arm/twist", "linear": [0.0, 0.0, 0.05], "angular": [0, 0, 0]})
        await asyncio.sleep(0.05)

    def settled() -> bool:
        recent = joint_states(client, robot)[-20:]
        if len(recent) < 20:
            return False
        last: list[float] = recent[-1]["positions"]
        return all(abs(a - b) < 1e-6 for m in recent for a, b in zip(m["positions"], last, strict=True))

    await wait_until(settled, 10, f"{robot}'s arm standing still after the twists stopped")
    return float(first["points"][-1][2]), joint_states(client, robot)[-1]
