"""An arm over Zenoh (issue #32): the demo fleet as tools/fake_fleet_zenoh.py runs it, robot3 with the real
TurtleBot3 manipulator's arm (tools/fake_arm.py), a relay on the zenoh backend (relay/backends/zenoh_arms.py). The
arm's JointState reaches the twin as CDR on rmw_zenoh's keys; an operator's twists reach MoveIt Servo's topic as a
TwistStamped in the arm's base link and move the gripper; they stop, and so does the arm."""

from __future__ import annotations

import asyncio

import pytest

pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.cli.options import Options, ZenohOptions
from relay.config import load_config
from tests.conftest import ROOT, start_relay
from tests.helpers.arm import jog_up_and_settle, tb3_manipulation
from tests.helpers.zenoh import demo_fleet_over_zenoh
from tests.wsclient import TestClient


async def test_the_demo_fleets_arm_over_zenoh_follows_the_operator_and_stops_when_the_twists_stop() -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")  # robot3's arm: without the shared data it runs as a base
    async with demo_fleet_over_zenoh() as endpoint:
        options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(endpoint,)))
        running = await start_relay(await asyncio.to_thread(load_config, ROOT / "robots.yaml"), options=options)
        client = await TestClient.open(running.ws_url)
        try:
            await client.hello()
            start, joints = await jog_up_and_settle(client, "robot3")
            assert joints["names"][:4] == ["joint1", "joint2", "joint3", "joint4"], joints["names"]
            assert joints["points"][-1][2] > start + 0.02, (start, joints["points"][-1])
        finally:
            await client.close()
            await running.runner.cleanup()
