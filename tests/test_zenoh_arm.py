"""An arm over Zenoh (issue #32): the demo fleet as tools/fake_fleet_zenoh.py runs it, robot3 with the real
TurtleBot3 manipulator's arm (tools/fake_arm.py), a relay on the zenoh backend (relay/backends/zenoh_arms.py). The
arm's JointState reaches the twin as CDR on rmw_zenoh's keys; an operator's twists reach MoveIt Servo's topic as a
TwistStamped in the arm's base link and move the gripper; they stop, and so does the arm. Named poses and the gripper
reach the arm's and the gripper's controllers (tools/fake_arm.py behind them)."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import pytest

pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.arm.srdf import load_group_states
from relay.cli.options import Options, ZenohOptions
from relay.config import load_config
from tests.conftest import ROOT, start_relay
from tests.helpers.arm import jog_up_and_settle, joint_states, tb3_manipulation
from tests.helpers.waiting import wait_until
from tests.helpers.zenoh import demo_fleet_over_zenoh
from tests.wsclient import TestClient

GRIPPER = "gripper_left_joint"


@contextlib.asynccontextmanager
async def operator_over_zenoh() -> AsyncIterator[TestClient]:
    """The demo fleet over Zenoh (tools/fake_fleet_zenoh.py), a relay on the zenoh backend, and a client of it that
    has robot3's joints."""
    async with demo_fleet_over_zenoh() as endpoint:
        options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(endpoint,)))
        running = await start_relay(await asyncio.to_thread(load_config, ROOT / "robots.yaml"), options=options)
        client = await TestClient.open(running.ws_url)
        try:
            await client.hello()
            await client.wait_for(lambda m: m["identifier"] == "robot3/joints", timeout=30)
            yield client
        finally:
            await client.close()
            await running.runner.cleanup()


async def test_the_demo_fleets_arm_over_zenoh_follows_the_operator_and_stops_when_the_twists_stop() -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")  # robot3's arm: without the shared data it runs as a base
    async with operator_over_zenoh() as client:
        start, joints = await jog_up_and_settle(client, "robot3")
        assert joints["names"][:4] == ["joint1", "joint2", "joint3", "joint4"], joints["names"]
        assert joints["points"][-1][2] > start + 0.02, (start, joints["points"][-1])


async def test_over_zenoh_a_named_pose_and_the_gripper_reach_the_arms_controllers() -> None:
    """``home`` goes to the arm controller as a JointTrajectory of the SRDF's joints, and the arm gets there; ``close``
    goes to the gripper controller as a GripperCommand goal of the SRDF's position, and the fingers close; a pose the
    SRDF lacks is refused by the relay, naming those it has, and nothing moves."""
    srdf = tb3_manipulation("config", "turtlebot3_manipulation.srdf")
    home = load_group_states(srdf)["arm"]["home"]
    closed = load_group_states(srdf)["gripper"]["close"][GRIPPER]
    async with operator_over_zenoh() as client:
        for command in ({"identifier": "robot3/arm/pose", "name": "home"},
                        {"identifier": "robot3/arm/gripper", "state": "close"}):  # fmt: skip
            answer = await client.request(command, 10)
            assert answer["identifier"] == "ack", answer

        def there() -> bool:
            last = joint_states(client, "robot3")[-1]
            joints = dict(zip(last["names"], last["positions"], strict=True))
            return all(abs(joints[j] - v) < 1e-3 for j, v in (*home.items(), (GRIPPER, closed)))

        # At a tenth of the joints' speed limits: the farthest (joint2, 1 rad) takes about 2 s.
        await wait_until(there, 20, "robot3's arm at home and its gripper closed")
        refusal = await client.request({"identifier": "robot3/arm/pose", "name": "stow"}, 10)
        assert refusal["code"] == "arm_refused" and "home" in refusal["message"], refusal
