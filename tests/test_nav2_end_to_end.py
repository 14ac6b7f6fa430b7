"""Issue #27's first promise, end to end: the real relay, the real fake fleet navigating as Nav2 does, a real estop.

Before: with tools/fake_fleet.py (DDS, and `--zenoh` with two relays), robot2 sent to (9, 6) kept driving 0.9-1.0 m
in the 1.5 s after an acknowledged estop while its status said `idle`, `estopped: true`, `goal: null`: the relay
held no Nav2 action and Nav2's controller drove on. Now every process is the one users run: `tools/fake_fleet.py
--nav2` (its navigators' controllers publish cmd_vel_nav at 20 Hz, its watchdogs own cmd_vel), `python -m relay`
over DDS or Zenoh, and a WebSocket operator. From 0.3 s after the estop's ack the robot moves at most 5 cm, and
once a status says estopped it never moves more than that again.
"""

from __future__ import annotations

import asyncio
import itertools
import math
import os
import secrets
import signal
import socket
import sys
from pathlib import Path
from typing import Any

import pytest

from relay.config import load_config
from relay.sim.world import SimWorld
from tests.conftest import LOAD_SLACK, ROOT, relay_process
from tests.wsclient import TestClient

#: From the ack on, this long for the stop to take hold (the issue's 0.3 s, plus what a loaded machine may add:
#: tests/conftest.py), then at most DRIFT of motion. Before, the robot drove on: 0.9-1.0 m in 1.5 s, and more.
HOLD, DRIFT = 0.3 + LOAD_SLACK, 0.05


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


async def start(*args: str, log: Path) -> asyncio.subprocess.Process:
    """A process of this test's environment (its ROS domain) that says it is ready on its first line; its log to
    ``log``."""
    with log.open("ab") as sink:
        process = await asyncio.create_subprocess_exec(
            sys.executable, *args, cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=sink, env=dict(os.environ)
        )
    assert process.stdout is not None
    line = await asyncio.wait_for(process.stdout.readline(), 60)
    assert line, f"{args[0]} exited before it was ready"
    return process


async def stop(*processes: asyncio.subprocess.Process | None) -> None:
    for process in processes:
        if process is not None and process.returncode is None:
            process.send_signal(signal.SIGTERM)
            try:
                await asyncio.wait_for(process.wait(), 10)
            except TimeoutError:
                process.kill()
                await process.wait()


async def operator(base: str, token: str) -> TestClient:
    client = await TestClient.open(base.replace("http", "ws") + f"/ws?token={token}")
    await client.hello()
    return client


def poses(client: TestClient, robot: str, since: float) -> list[tuple[float, float, float]]:
    """(time received, x, y) of ``robot``'s poses from ``since``."""
    return [(t, m["x"], m["y"]) for t, m in client.messages if t >= since and m["identifier"] == f"{robot}/pose"]


def moved(samples: list[tuple[float, float, float]]) -> float:
    """How far the robot got from the first sample, at most."""
    return max((math.hypot(x - samples[0][1], y - samples[0][2]) for _, x, y in samples), default=0.0)


def tails(logs: Path) -> str:
    """The last lines of every process's log in ``logs``, for a failure's message."""
    return "\n".join(
        f"--- {log.name}:\n" + "\n".join(log.read_text(errors="replace").splitlines()[-15:])
        for log in sorted(logs.glob("*.log"))
    )


async def drive_then_estop(driver: TestClient, stopper: TestClient, robot: str, logs: Path) -> None:
    """``driver`` sends ``robot`` to (9, 6) and, once it rolls, ``stopper`` presses E-STOP; then the checks. ``logs``
    holds the processes' logs, quoted when the robot does not roll."""
    start_pose = await driver.wait_for(lambda m: m["identifier"] == f"{robot}/pose", timeout=60)
    goal = await driver.request({"identifier": f"{robot}/goal_pose", "x": 9.0, "y": 6.0}, timeout=30)
    assert goal["identifier"] == "ack", goal
    try:
        await driver.wait_pose_near(robot, start_pose["x"], start_pose["y"] + 0.6, 0.35, timeout=60)  # rolling
    except TimeoutError:
        heard = [m for _, m in driver.messages if m["identifier"] == f"{robot}/nav" or m["identifier"] == "error"]
        raise AssertionError(f"{robot} never rolled; the relay said: {heard[-6:]}\n{tails(logs)}") from None

    # Nav2's feedback while it drives: the distance left shrinks (decoded from Nav2's own definition).
    def feedback(m: dict[str, Any], below: float = math.inf) -> bool:
        return bool(m["identifier"] == f"{robot}/nav" and m.get("feedback")) and (
            m["feedback"]["distance_remaining"] < below
        )

    first = await driver.wait_for(feedback, timeout=10)
    later = await driver.wait_for(lambda m: feedback(m, first["feedback"]["distance_remaining"] - 0.1), timeout=10)
    assert 0 < later["feedback"]["distance_remaining"] < 12 and later["feedback"]["eta"] >= 0, later
    reply = await stopper.request({"identifier": "estop"}, timeout=10)
    assert reply["identifier"] == "ack", reply
    acked = next(t for t, m in stopper.messages if m.get("id") == reply["id"])
    await asyncio.sleep(HOLD + 2.5)
    after = poses(stopper, robot, acked + HOLD)
    assert len(after) > 10, "too few poses to judge the stop"
    assert moved(after) <= DRIFT, f"{robot} moved {moved(after):.3f} m from {HOLD} s after the estop's ack"
    # The status never says stopped while the robot moves: from the first status that says estopped (and HOLD for
    # it to take hold), nothing.
    said = next(
        t for t, m in stopper.messages if m["identifier"] == f"{robot}/status" and m.get("estopped") and t >= acked - 1
    )
    assert moved(poses(stopper, robot, said + HOLD)) <= DRIFT
    nav = [m for _, m in driver.messages if m["identifier"] == f"{robot}/nav"]
    assert nav and nav[-1]["outcome"] == "cancelled", nav[-3:]


@pytest.fixture
def token() -> str:
    return secrets.token_urlsafe(24)


def occupied_point() -> tuple[float, float]:
    """A point of the demo's map inside a wall (Nav2's costmap says occupied), near the middle of the site."""
    world = SimWorld(load_config(ROOT / "robots.yaml"), on_nav=lambda *_: None)
    for x, y in sorted(itertools.product(range(1, 18), range(1, 10)), key=lambda p: math.hypot(p[0] - 9, p[1] - 5)):
        if world.grid.in_bounds(x, y) and not world.planner.inflated.is_free(x, y):
            return float(x), float(y)
    raise AssertionError("the demo's map has no wall")


async def aborted_with_nav2s_code(client: TestClient, robot: str) -> None:
    """A goal inside a wall: Nav2 aborts it, and the relay reports its error code, asked with GetResult."""
    x, y = await asyncio.to_thread(occupied_point)
    start = len(client.messages)
    reply = await client.request({"identifier": f"{robot}/goal_pose", "x": x, "y": y}, timeout=30)
    assert reply["identifier"] == "ack", reply
    failed = await client.wait_for(
        lambda m: m["identifier"] == f"{robot}/nav" and m["outcome"] == "failed", timeout=10, start=start
    )
    assert failed["error_code"] == 206 and "goal occupied" in failed["message"], failed  # ComputePathToPose's code


@pytest.mark.ros
@pytest.mark.slow
async def test_over_dds_an_estop_stops_a_robot_that_nav2_drives(ros_domain: int, token: str, tmp_path: Path) -> None:
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'` installs the ROS 2 wheels")
    # Nav2's feedback and error codes over DDS need nav2_msgs; the wheels have none, `make setup` builds it.
    pytest.importorskip("nav2_msgs.action", reason="no nav2_msgs: `make setup` builds it (tools/build_nav2_msgs.py)")
    processes: list[asyncio.subprocess.Process | None] = []  # every one is stopped, whatever fails
    relay_args = (
        "--backend", "ros", "--config", str(ROOT / "robots.yaml"), f"--token={token}", "--audit-log", "",
        "--database", str(tmp_path / "i.sqlite"),
    )  # fmt: skip
    try:
        fleet = str(ROOT / "tools" / "fake_fleet.py")
        processes.append(await start(fleet, "--nav2", "--log-level", "info", log=tmp_path / "fleet.log"))
        with (tmp_path / "relay.log").open("ab") as log:
            relay, base = await relay_process(*relay_args, stderr=log)
        processes.append(relay)
        client = await operator(base, token)
        await drive_then_estop(client, client, "robot2", tmp_path)
        # Released, a goal in a wall: Nav2's abort with its error code (after the drive: the relay's GetResult client
        # has matched Nav2's server by then; a relay just started waits 0.5 s for it, then reports no code).
        assert (await client.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"
        await aborted_with_nav2s_code(client, "robot1")
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        await client.wait_for(lambda m: m["identifier"] == "robot2/status" and m.get("estopped") is True, timeout=10)
        await client.close()
        # The latch holds on the robot: the relay killed, the base still gets nothing that moves it, and a new relay
        # learns the latch from the robot's watchdog.
        relay.send_signal(signal.SIGKILL)
        await relay.wait()
        relay, base = await relay_process(*relay_args)
        processes.append(relay)
        watcher = await operator(base, token)
        latched = await watcher.wait_for(
            lambda m: m["identifier"] == "robot2/status" and m.get("estopped") is True, timeout=30
        )
        assert latched["estopped"] is True
        await watcher.close()
    finally:
        await stop(*reversed(processes))


@pytest.mark.slow
@pytest.mark.parametrize("relays", [1, 2])
async def test_over_zenoh_an_estop_stops_a_robot_that_nav2_drives(relays: int, token: str, tmp_path: Path) -> None:
    """With two relays the operator of one drives and the other's presses E-STOP: the fleet's estop reaches the
    first, and the robot's gate holds it."""
    pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    processes: list[asyncio.subprocess.Process | None] = []
    try:
        fleet = str(ROOT / "tools" / "fake_fleet.py")
        processes.append(
            await start(
                fleet, "--zenoh", "--nav2", "--listen", endpoint, "--log-level", "info", log=tmp_path / "fleet.log"
            )
        )
        clients = []
        for index in range(relays):
            with (tmp_path / f"relay{index}.log").open("ab") as log:
                relay, base = await relay_process(
                    "--backend", "zenoh", "--config", str(ROOT / "robots.yaml"), "--zenoh-connect", endpoint,
                    "--relay-id", f"R{index}", f"--token={token}", "--audit-log", "",
                    "--database", str(tmp_path / f"{index}.sqlite"), stderr=log,
                )  # fmt: skip
            processes.append(relay)
            clients.append(await operator(base, token))
        await drive_then_estop(clients[0], clients[-1], "robot2", tmp_path)
        for client in clients:
            await client.close()
    finally:
        await stop(*reversed(processes))
