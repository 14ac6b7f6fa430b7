"""Two relays, one fleet, over one Zenoh router on 127.0.0.1: relay A in this process, relay B in a process of its
own (so that it can be killed). A lease held through B refuses A's commands, naming B's operator and relay; an
estop on A stops and latches the robots on B; once B is killed its lease goes with it and A's operator takes the
robot. tests/test_zenoh_backend.py has the router and the robots' side.
"""

from __future__ import annotations

import asyncio
import math
import signal
import sys
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.config import load_config
from relay.options import Options, ZenohOptions
from tests.conftest import ROOT, relay_process, start_relay
from tests.test_zenoh_backend import FLEET, Router, decode, router, until, zenoh_relay  # noqa: F401
from tests.wsclient import TestClient
from tests.zenoh_robots import free_port

pytestmark = pytest.mark.slow


async def test_estop_and_leases_are_shared_by_two_relays_and_a_killed_relay_frees_its_robot(
    router: Router,  # noqa: F811 - the fixture
    tmp_path: Path,
) -> None:
    twists = router.listen("0/alpha/cmd_vel/*/*")
    config = tmp_path / "fleet.yaml"
    config.write_text(FLEET)
    relay_b, base_b = await relay_process(
        "--backend", "zenoh", "--config", str(config), "--zenoh-connect", router.endpoint, "--relay-id", "B",
        "--token", "t", "--allow-weak-token", "--audit-log", "", "--database", str(tmp_path / "b.sqlite"),
    )  # fmt: skip
    running_a = await zenoh_relay(router, relay_id="A")
    client_a = await TestClient.open(running_a.ws_url)
    client_b = await TestClient.open(base_b.replace("http", "ws") + "/ws?token=t")
    try:
        await client_a.hello()
        await client_b.hello()
        # B's operator drives alpha: B holds its lease, and its token reaches A.
        reply = await client_b.request({"identifier": "alpha/cmd_vel", "linear": 0.2, "angular": 0.0})
        assert reply["identifier"] == "ack", reply
        deadline = time.monotonic() + 10
        while True:
            reply = await client_a.request({"identifier": "alpha/cmd_vel", "linear": 0.1, "angular": 0.0})
            if reply["identifier"] == "error" or time.monotonic() > deadline:
                break
            await asyncio.sleep(0.1)  # the token is still on its way: A took the lease meanwhile, and gives it back
            await client_a.request({"identifier": "alpha/lease", "action": "release"})
        assert reply["identifier"] == "error" and reply["code"] == "leased", reply
        assert "through relay B" in reply["message"], reply
        assert (await client_a.request({"identifier": "alpha/lease"}))["code"] == "leased"
        assert (await client_a.request({"identifier": "alpha/lease", "force": True}))["code"] == "leased"

        # An estop on A stops and latches alpha and beta on B too.
        start = len(twists.all())
        reply = await client_a.request({"identifier": "estop"})
        assert reply["identifier"] == "ack", reply
        estop = await client_b.wait_for(lambda m: m["identifier"] == "estop" and m.get("latched", True), timeout=5)
        assert set(estop["robots"]) == {"alpha", "beta"} and "via relay A" in str(estop["by"])
        reply = await client_b.request({"identifier": "alpha/cmd_vel", "linear": 0.2, "angular": 0.0})
        assert reply["identifier"] == "error" and reply["code"] == "estopped", reply
        # Both relays sent alpha a zero Twist (their own publishers: two GIDs in the attachments).
        gids = {
            extra[17:] for _, payload, extra in twists.all()[start:] if extra and not decode(payload, TWIST).linear.x
        }
        assert len(gids) == 2, gids

        # B dies without a word: its lease token goes with its session, and A's operator takes alpha.
        relay_b.send_signal(signal.SIGKILL)
        await relay_b.wait()
        deadline = time.monotonic() + 15
        while (reply := await client_a.request({"identifier": "alpha/lease"}))["identifier"] != "ack":
            assert time.monotonic() < deadline, reply
            await asyncio.sleep(0.2)
    finally:
        await client_a.close()
        await running_a.runner.cleanup()
        if relay_b.returncode is None:
            relay_b.kill()
            await relay_b.wait()


TWIST = "geometry_msgs/msg/Twist"


def distance(a: dict[str, Any] | None, b: dict[str, Any] | None) -> float:
    assert a is not None and b is not None
    return math.hypot(a["x"] - b["x"], a["y"] - b["y"])


async def test_a_killed_relays_robot_is_stopped_by_its_watchdog_and_freed_for_the_other_relay(tmp_path: Path) -> None:
    """The demo fleet over Zenoh (tools/fake_fleet_zenoh.py: robots with cmd_vel.watchdog, the watchdog's rules on
    the robots' side): relay B drives robot2 and is killed mid-drive; the heartbeat stops, the watchdog stops robot2
    (relay A sees it stand still), and A's operator gets robot2's lease."""
    port = free_port()
    fleet = await asyncio.create_subprocess_exec(
        sys.executable, str(ROOT / "tools" / "fake_fleet_zenoh.py"), "--listen", f"tcp/127.0.0.1:{port}",
        "--log-level", "warning", stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    assert fleet.stdout is not None
    relay_b = None
    try:
        assert b"a Zenoh router on" in await asyncio.wait_for(fleet.stdout.readline(), 30)
        endpoint = f"tcp/127.0.0.1:{port}"
        relay_b, base_b = await relay_process(
            "--backend", "zenoh", "--config", str(ROOT / "robots.yaml"), "--zenoh-connect", endpoint,
            "--relay-id", "B", "--token", "t", "--allow-weak-token", "--audit-log", "",
            "--database", str(tmp_path / "b.sqlite"),
        )  # fmt: skip
        options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(endpoint,), relay_id="A"))
        running_a = await start_relay(load_config(ROOT / "robots.yaml"), options=options)
        client_a = await TestClient.open(running_a.ws_url)
        client_b = await TestClient.open(base_b.replace("http", "ws") + "/ws?token=t")
        try:
            await client_a.hello()
            await client_b.hello()
            await until(lambda: client_a.pose("robot2"), 10, "robot2's pose on relay A")
            # B's operator drives robot2 (through its watchdog) until A sees it move.
            start = client_a.pose("robot2")
            assert start is not None
            deadline = time.monotonic() + 10
            while distance(client_a.pose("robot2"), start) < 0.2:
                assert time.monotonic() < deadline, "robot2 did not move"
                await client_b.send({"identifier": "robot2/cmd_vel", "linear": 0.4, "angular": 0.0})
                await asyncio.sleep(0.05)
            relay_b.send_signal(signal.SIGKILL)
            killed = time.monotonic()
            await relay_b.wait()
            # Stopped by the watchdog (relay A sends robot2 nothing): its pose stands still for a second.
            still_since, last = time.monotonic(), client_a.pose("robot2")
            while time.monotonic() - still_since < 1.0:
                assert time.monotonic() - killed < 5, "robot2 kept moving after its relay died"
                await asyncio.sleep(0.1)
                now = client_a.pose("robot2")
                if distance(now, last) > 0.005:
                    still_since, last = time.monotonic(), now
            deadline = time.monotonic() + 15
            while (reply := await client_a.request({"identifier": "robot2/lease"}))["identifier"] != "ack":
                assert time.monotonic() < deadline, reply
                await asyncio.sleep(0.2)
        finally:
            await client_a.close()
            await running_a.runner.cleanup()
    finally:
        if relay_b is not None and relay_b.returncode is None:
            relay_b.kill()
            await relay_b.wait()
        fleet.terminate()
        await asyncio.wait_for(fleet.wait(), 10)
