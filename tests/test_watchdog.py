"""The watchdog: robots stop when the relay cannot (a frozen, starved or cut-off relay), stale commands stay
stopped, and the watchdog is the robot's gate: teleop over autonomy, drive/hold/estop from the relay, an estop
latched against every source. Rules without ROS first (a clock moved by hand), then over real DDS with the relay
frozen by SIGSTOP mid-teleop; the gate over DDS and Zenoh with a fake Nav2 navigator: tests/test_gate.py."""

from __future__ import annotations

import asyncio
import importlib
import itertools
import os
import signal
import sys
import time
from pathlib import Path

import pytest

from relay.watchdog.rules import ESTOP_PERIOD, Verdict, WatchdogRules
from tests.conftest import LOAD_SLACK, ROOT, relay_process
from tests.wsclient import TestClient

TIMEOUT = 0.5


def alive(timeout: float = TIMEOUT, on_relay_lost: str = "hold", gate: str = "hold") -> WatchdogRules:
    rules = WatchdogRules(timeout, on_relay_lost)  # type: ignore[arg-type]
    rules.heartbeat(100.0)
    rules.set_gate(gate, 100.0)
    return rules


def ticks(rules: WatchdogRules, start: float, end: float, step: float = 0.02) -> list[tuple[float, str]]:
    """What a 50 Hz tick says between ``start`` and ``end``: (time, reason) of each zero."""
    out = []
    for i in range(round((end - start) / step)):
        now = start + i * step
        if (reason := rules.tick(now)) is not None:
            out.append((now, reason))
    return out


def test_fresh_commands_are_forwarded_and_a_silence_gets_one_zero() -> None:
    rules = alive()
    for i in range(10):  # 20 Hz teleop, heartbeats at 10 Hz; the relay's clock is 1e6 s ahead
        now = 100.0 + i * 0.05
        rules.heartbeat(now)
        assert rules.command(0.3, 0.0, 1e6 + now - 0.01, now).forward
    last = 100.45
    assert rules.tick(last + TIMEOUT - 0.01) is None
    assert rules.tick(last + TIMEOUT + 0.01) == "no teleop command for 0.51 s"
    assert rules.tick(last + TIMEOUT + 0.05) is None  # one zero, not a stream that would fight a planner


def test_a_relay_whose_heartbeat_stops_stops_the_robot_although_commands_keep_coming() -> None:
    # A relay whose event loop starves still gets commands out of its ROS thread? No: but a network that
    # delivers commands and loses heartbeats must not keep the robot going either.
    rules = alive()
    assert rules.command(0.3, 0.0, 99.99, 100.0).forward
    assert rules.tick(100.0 + TIMEOUT + 0.01) == "no teleop command for 0.51 s"
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


def test_the_gate_is_hold_until_the_relay_says_drive_and_hold_blocks_autonomy_but_not_teleop() -> None:
    rules = WatchdogRules(TIMEOUT)
    rules.heartbeat(100.0)
    assert rules.gate == "hold"  # a watchdog that (re)starts lets no autonomy through before the relay's word
    assert rules.autonomy(0.3, 0.1, 100.01) == Verdict(False, "the gate is hold")
    assert rules.command(0.2, 0.0, 100.0, 100.02).forward, "teleop passes a hold"
    assert rules.set_gate("drive", 100.6) is None
    rules.heartbeat(100.6)
    assert rules.autonomy(0.3, 0.1, 100.61).forward  # teleop's last command is 0.59 s old: autonomy's turn
    assert rules.moving


def test_teleop_overrides_autonomy_while_fresh_a_teleop_zero_included() -> None:
    rules = alive(gate="drive")
    assert rules.autonomy(0.3, 0.0, 100.0).forward
    assert rules.command(0.0, 0.5, 100.0, 100.05).forward  # the operator turns in place
    for now in (100.1, 100.3, 100.55):
        rules.heartbeat(now)
        assert rules.autonomy(0.3, 0.0, now) == Verdict(False, "teleop overrides autonomy")
    assert rules.command(0.0, 0.0, 100.55, 100.56).forward  # released: a zero, forwarded
    rules.heartbeat(100.9)
    assert rules.autonomy(0.3, 0.0, 100.9) == Verdict(False, "teleop overrides autonomy"), "a teleop zero counts"
    assert rules.autonomy(0.3, 0.0, 101.07).forward, "0.51 s after teleop's last word, autonomy drives again"


def test_cutting_autonomy_off_with_hold_is_one_zero_at_once_and_a_quiet_source_one_zero() -> None:
    rules = alive(gate="drive")
    for i in range(10):  # Nav2's controller at 20 Hz
        assert rules.autonomy(0.3, 0.0, 100.0 + i * 0.05).forward
    assert rules.set_gate("hold", 100.47) == "the gate is hold: autonomy is blocked"
    assert not rules.moving and rules.tick(100.48) is None
    assert rules.autonomy(0.3, 0.0, 100.5) == Verdict(False, "the gate is hold")
    assert rules.set_gate("hold", 100.52) is None, "the same word again changes nothing"
    rules.set_gate("drive", 100.6)
    rules.heartbeat(100.6)
    assert rules.autonomy(0.3, 0.0, 100.6).forward
    [(at, reason)] = ticks(rules, 100.62, 101.5)  # one zero, not a stream that would fight the next source
    assert 100.6 + TIMEOUT < at <= 100.6 + TIMEOUT + 0.02 and reason.startswith("no autonomy command for 0.5")


def test_an_estop_latches_zero_at_20_hz_and_nothing_passes_from_any_source_until_drive() -> None:
    rules = alive(gate="drive")
    assert rules.autonomy(0.3, 0.0, 100.0).forward
    assert rules.set_gate("estop", 100.01) == "estop latched", "a zero at once"
    assert rules.gate == "estop" and not rules.moving
    zeros = []
    for i in range(1, 150):  # 3 s of 50 Hz ticks, the controller and the operator pushing all along
        now = 100.01 + i * 0.02
        rules.heartbeat(now)
        assert rules.autonomy(0.3, 0.0, now).reason.startswith("estop latched")
        assert not rules.command(0.4, 0.0, now, now).forward
        assert not rules.command(0.0, 0.0, now, now).forward, "not even a teleop zero: the latch sends its own"
        if rules.tick(now) is not None:
            zeros.append(now)
    assert len(zeros) == 3.0 / ESTOP_PERIOD - 1  # 20 Hz, the first 50 ms after the one at once
    assert max(b - a for a, b in itertools.pairwise(zeros)) <= 0.06 + 1e-9
    assert rules.set_gate("drive", 103.0) is None
    assert rules.tick(103.02) is None and rules.tick(103.1) is None, "the zeros stop with the latch"
    assert rules.command(0.0, 0.0, 103.0, 103.05).forward
    rules.heartbeat(103.6)
    assert rules.autonomy(0.3, 0.0, 103.6).forward, "drive lets autonomy drive again"


def test_an_estop_outlives_the_relay_and_leaving_it_for_hold_still_blocks_autonomy() -> None:
    rules = alive(gate="drive")
    rules.set_gate("estop", 100.0)
    zeros = ticks(rules, 100.02, 130.0)  # the relay is dead: no heartbeat for 30 s
    assert len(zeros) == pytest.approx(30.0 / ESTOP_PERIOD, abs=2)
    assert not rules.autonomy(0.3, 0.0, 130.0).forward
    rules.heartbeat(131.0)  # a new relay, which learnt the latch from gate_state, resets it with hold
    assert rules.set_gate("hold", 131.0) is None
    assert rules.autonomy(0.3, 0.0, 131.01) == Verdict(False, "the gate is hold")
    assert rules.command(0.2, 0.0, 131.0, 131.02).forward


def test_a_late_tick_starts_the_estop_zeros_afresh_rather_than_in_a_burst() -> None:
    rules = alive()
    rules.set_gate("estop", 100.0)
    assert rules.tick(100.05) == "estop latched"
    assert rules.tick(100.6) == "estop latched"  # the watchdog was starved for half a second
    assert rules.tick(100.62) is None and rules.tick(100.64) is None and rules.tick(100.66) is not None


@pytest.mark.parametrize("on_relay_lost", ["hold", "continue"])
def test_when_the_heartbeat_stops_autonomy_holds_or_continues_as_configured(on_relay_lost: str) -> None:
    rules = alive(on_relay_lost=on_relay_lost, gate="drive")  # the relay's last heartbeat: 100.0
    forwarded, zeros = [], []
    for i in range(60):  # the controller goes on at 20 Hz for 3 s
        now = 100.0 + i * 0.05
        forwarded.append(rules.autonomy(0.3, 0.0, now).forward)
        if (reason := rules.tick(now + 0.01)) is not None:
            zeros.append((now + 0.01, reason))
    if on_relay_lost == "hold":
        assert forwarded == [i * 0.05 <= TIMEOUT for i in range(60)]
        [(at, reason)] = zeros
        assert 100.0 + TIMEOUT < at <= 100.0 + TIMEOUT + 0.05 and reason == (
            "the relay's heartbeat stopped (on_relay_lost: hold)"
        )
    else:
        assert all(forwarded) and zeros == [] and rules.moving
    assert not rules.command(0.3, 0.0, 103.0, 103.0).forward, "teleop stops either way"


def test_a_gate_word_that_is_not_one_changes_nothing() -> None:
    rules = alive(gate="drive")
    with pytest.raises(ValueError, match=r"a gate is one of drive, hold, estop, got 'STOP.{36}'$"):
        rules.set_gate("STOP" + "!" * 100, 100.0)
    assert rules.gate == "drive"


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
    # Off the loop: the first import of the ROS helpers (trimesh, rclpy) took 0.8 s on a loaded machine, which the
    # loop-blocking check rightly reports.
    start_peer = (await asyncio.to_thread(importlib.import_module, "tests.helpers.ros")).start_peer

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
    relay, base = await relay_process(
        "--backend", "ros", "--config", str(config), "--token", "t", "--allow-weak-token", "--audit-log", ""
    )
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
        # The watchdog's timeout, its 20 Hz check and DDS; a loaded machine adds scheduling (0.67 s seen in CI).
        lag = zeros[0]["t"] - stopped
        assert lag <= TIMEOUT + 0.1 + LOAD_SLACK, f"the stop came {lag:.3f} s after SIGSTOP"
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
