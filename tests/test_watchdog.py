"""The watchdog: robots stop when the relay cannot (a frozen, starved or cut-off relay), and stale commands stay
stopped. Rules without ROS first, then over real DDS with the relay frozen by SIGSTOP mid-teleop."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import time
from pathlib import Path

import pytest

from relay.watchdog.rules import WatchdogRules
from tests.conftest import ROOT, relay_process
from tests.wsclient import TestClient

TIMEOUT = 0.5


def alive(timeout: float = TIMEOUT) -> WatchdogRules:
    rules = WatchdogRules(timeout)
    rules.heartbeat(100.0)
    return rules


def test_fresh_commands_are_forwarded_and_a_silence_gets_one_zero() -> None:
    rules = alive()
    for i in range(10):  # 20 Hz teleop, heartbeats at 10 Hz; the relay's clock is 1e6 s ahead
        now = 100.0 + i * 0.05
        rules.heartbeat(now)
        assert rules.command(0.3, 0.0, 1e6 + now - 0.01, now).forward
    last = 100.45
    assert rules.tick(last + TIMEOUT - 0.01) is None
    assert rules.tick(last + TIMEOUT + 0.01) == "no command for 0.51 s"
    assert rules.tick(last + TIMEOUT + 0.05) is None  # one zero, not a stream that would fight a planner


def test_a_relay_whose_heartbeat_stops_stops_the_robot_although_commands_keep_coming() -> None:
    # A relay whose event loop starves still gets commands out of its ROS thread? No: but a network that
    # delivers commands and loses heartbeats must not keep the robot going either.
    rules = alive()
    assert rules.command(0.3, 0.0, 99.99, 100.0).forward
    assert rules.tick(100.0 + TIMEOUT + 0.01) == "no command for 0.51 s"
    verdict = rules.command(0.3, 0.0, 100.5, 100.51)
    assert not verdict.forward and verdict.reason == "no heartbeat from the relay"
    rules.heartbeat(100.6)
    assert rules.command(0.3, 0.0, 100.6, 100.61).forward
    assert rules.tick(100.6 + TIMEOUT + 0.01) is not None


def test_stale_commands_are_dropped_and_stops_always_go_through() -> None:
    rules = alive()
    for i in range(10):
        now = 100.0 + i * 0.05
        rules.heartbeat(now)
        assert rules.command(0.3, 0.0, now - 0.01, now).forward
    # A burst of commands that waited 1-3 s somewhere (a relay resumed after SIGSTOP): none moves the robot.
    rules.heartbeat(103.0)
    for age in (3.0, 2.0, 1.0, 0.6):
        verdict = rules.command(0.3, 0.0, 103.0 - age, 103.0)
        assert not verdict.forward and verdict.reason.startswith("stale"), verdict
    assert rules.command(0.0, 0.0, 100.0, 103.0).forward  # a zero, however old, is a stop
    assert not rules.moving


# -- over DDS -------------------------------------------------------------------------------------

FLEET = """
safety: {deadman_timeout: 0.5, offline_after: 2.0}
robots:
  - name: alpha
    pose: odom
    limits: {linear: 0.5, angular: 1.0}
    scan: null
    cmd_vel: {watchdog: true}
"""


@pytest.mark.ros
async def test_a_relay_frozen_mid_teleop_leaves_its_robot_stopped(ros_domain: int, tmp_path: Path) -> None:
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'` installs the ROS 2 wheels")
    from tests.helpers.ros import start_peer

    config = tmp_path / "fleet.yaml"
    config.write_text(FLEET)
    peer = await start_peer(
        {"poses": [{"kind": "odom", "topic": "/alpha/odom", "x": 1.0, "y": 1.0, "yaw": 0.0}],
         "echo_twist": ["/alpha/cmd_vel"]},
        tmp_path,
    )  # fmt: skip
    watchdog = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", "watchdog", "--config", str(config), cwd=ROOT,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env=dict(os.environ),
    )  # fmt: skip
    relay, base = await relay_process("--backend", "ros", "--config", str(config), "--token", "t", "--audit-log", "")
    try:
        assert watchdog.stdout is not None
        assert b"watching alpha" in await asyncio.wait_for(watchdog.stdout.readline(), 60)
        client = await TestClient.open(base.replace("http", "ws") + "/ws?token=t")
        await client.hello()

        def drive() -> dict[str, object]:
            t = time.monotonic() * 1000  # the browser's performance.now(): any monotonic clock in ms
            return {"identifier": "alpha/cmd_vel", "linear": 0.4, "angular": 0.2, "t": t}

        moving = False
        deadline = time.monotonic() + 30
        while not moving and time.monotonic() < deadline:  # until DDS has matched every hop
            await client.send(drive())
            await asyncio.sleep(0.05)
            moving = any(m.get("linear") == 0.4 for m in peer.lines)
        assert moving, "the watchdog never forwarded the relay's teleop to /alpha/cmd_vel"
        for _ in range(10):  # half a second of steady teleop
            await client.send(drive())
            await asyncio.sleep(0.05)

        relay.send_signal(signal.SIGSTOP)
        stopped = time.monotonic()
        start = len(peer.lines)
        for _ in range(30):  # the operator keeps driving for 1.5 s: the frames wait in the frozen relay's socket
            await client.send(drive())
            await asyncio.sleep(0.05)
        await asyncio.sleep(1.5)
        relay.send_signal(signal.SIGCONT)
        resumed = time.monotonic()
        await asyncio.sleep(1.5)  # the relay handles the buffered frames, 1.5-3 s old

        after = [m for m in peer.lines[start:] if m.get("topic") == "/alpha/cmd_vel"]
        zeros = [m for m in after if m["linear"] == 0.0 and m["angular"] == 0.0]
        assert zeros, f"no zero Twist reached the robot while the relay was frozen: {after}"
        assert zeros[0]["t"] - stopped <= TIMEOUT + 0.1, f"the stop came {zeros[0]['t'] - stopped:.3f} s after SIGSTOP"
        assert zeros[0]["t"] < resumed
        moved_after_stop = [m for m in after if m["t"] > zeros[0]["t"] and (m["linear"] or m["angular"])]
        assert not moved_after_stop, f"stale commands reached the robot after its stop: {moved_after_stop}"

        # A fresh command drives again: the relay and the watchdog recovered by themselves.
        start = len(peer.lines)
        for _ in range(20):
            await client.send(drive())
            await asyncio.sleep(0.05)
        assert any(m.get("linear") == 0.4 for m in peer.lines[start:]), "fresh teleop did not drive after the freeze"
        await client.close()
    finally:
        for process in (relay, watchdog):
            if process.returncode is None:
                process.send_signal(signal.SIGCONT)
                process.kill()
                await process.wait()
        await peer.stop()
