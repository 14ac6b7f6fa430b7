"""The loop's stalls measured, and client frames dated by the read that brought them (relay.net.loop_lag).

Pure rules first (times passed in), then a real relay process frozen by SIGSTOP while a client that does not stamp
its commands keeps driving: none of the commands that waited reaches the robot.
"""

from __future__ import annotations

import asyncio
import math
import secrets
import signal
import socket
import time

import pytest

from relay.net.loop_lag import ArrivalDates, LagStats, LoopLag, unread_bytes
from tests.conftest import ROOT, relay_process
from tests.wsclient import TestClient


def test_lag_stats_give_p99_worst_and_worst_ever() -> None:
    stats = LagStats(window=100)
    for _ in range(98):
        stats.add(0.001)
    stats.add(0.2)
    stats.add(0.05)
    assert stats.worst() == 0.2
    assert stats.p99() == 0.05  # the 99th of 100 ordered values
    for _ in range(100):
        stats.add(-0.001)  # a beat that ran early counts as on time
    assert stats.worst() == 0.0 and stats.worst_ever == 0.2
    assert stats.report() == {"p99_ms": 0.0, "worst_ms": 0.0, "worst_ever_ms": 200.0}


def test_bytes_read_after_a_stall_are_dated_to_its_start() -> None:
    lag = LoopLag(clock=lambda: 0.0, period=0.01, stall=0.05)
    lag.last_beat = 100.0
    assert lag.arrival(100.02) == 100.02  # an ordinary read: now
    assert lag.arrival(103.0) == 100.0  # the loop did not run for 3 s: the bytes may have waited all of it


def test_a_stall_the_beat_sees_first_is_told_to_the_connections_with_unread_bytes() -> None:
    """A SIGSTOP between the loop's select and its callbacks resumes with the beat first: under load, 60 of 60
    commands that waited out a 3 s freeze were carried out, read just after a beat that had seen the stall. Now the
    late beat tells the connections; one whose socket holds unread bytes dates them to the stall's start."""
    lag = LoopLag(clock=lambda: 0.0, period=0.01, stall=0.05)
    told: list[float] = []
    forget = lag.on_stall(told.append)
    lag.beat(100.0, due=100.0)
    lag.beat(100.04, due=100.01)  # 30 ms late: not a stall
    lag.beat(103.0, due=100.05)  # the late beat, first after the freeze
    assert told == [100.04]
    dates = ArrivalDates(now=0.0)
    dates.read(told[0])  # what the server does for a connection with unread bytes
    dates.read(lag.arrival(103.001))  # then the read: a loop that has just run, dated now
    assert dates.frame() == 100.04
    forget()
    lag.beat(110.0, due=109.0)
    assert told == [100.04]


def test_the_kernel_says_whether_a_connection_holds_unread_bytes() -> None:
    left, right = socket.socketpair()
    with left, right:
        transport = type("T", (), {"get_extra_info": lambda self, key: left if key == "socket" else None})()
        assert unread_bytes(transport) is False
        right.sendall(b'{"identifier":"robot1/cmd_vel"}')
        time.sleep(0.05)
        assert unread_bytes(transport) is True
        left.recv(100)
        assert unread_bytes(transport) is False


def test_frames_are_never_dated_later_than_the_read_that_brought_them() -> None:
    dates = ArrivalDates(now=0.0)
    dates.read(10.0)  # a read after a stall, dated to its start, bringing three frames
    dates.read(12.9)  # and another read before the handler got to the first frame
    assert [dates.frame(), dates.frame(), dates.frame()] == [10.0, 10.0, 10.0]
    dates.read(13.0)
    assert dates.frame() == 13.0  # a later read dates the frames after it


def drive(robot: str, rid: str) -> dict[str, object]:
    # What README's example sends: no `t`. The relay alone must tell how long it waited.
    return {"identifier": f"{robot}/cmd_vel", "id": rid, "linear": 0.0, "angular": 1.0}


@pytest.mark.slow
async def test_unstamped_teleop_that_waited_in_a_frozen_relay_never_moves_the_robot() -> None:
    """Issue #28, finding 4: a client that does not stamp cmd_vel had 9-14 stale commands replayed after a 3 s
    SIGSTOP of the relay, and the robot turned 0.3-0.4 rad. Now every command read after the freeze is dated to
    its start, refused as ``stale``, and the robot does not turn."""
    token = secrets.token_urlsafe(24)
    relay, base = await relay_process(
        "--backend", "sim", "--config", str(ROOT / "robots.yaml"), "--token", token, "--audit-log", ""
    )
    try:
        client = await TestClient.open(base.replace("http", "ws") + f"/ws?token={token}")
        await client.hello()
        # Fresh teleop is taken (request sends it again if a loaded machine starved the relay just then: stale).
        first = await client.request(drive("robot1", "x"))
        assert first["identifier"] == "ack", first
        await asyncio.sleep(1.5)  # the deadman stops it; the robot rests
        before = client.pose("robot1")
        assert before is not None

        relay.send_signal(signal.SIGSTOP)
        ids = [f"frozen{i}" for i in range(60)]
        for rid in ids:  # the operator keeps driving for 3 s: the frames wait in the frozen relay's socket
            await client.send(drive("robot1", rid))
            await asyncio.sleep(0.05)
        relay.send_signal(signal.SIGCONT)
        replies: dict[str, dict[str, object]] = {}
        deadline = time.monotonic() + 20
        while len(replies) < len(ids) and time.monotonic() < deadline:
            message = await client.wait_for(
                lambda m: m["identifier"] in ("ack", "error") and m.get("id") in ids and m["id"] not in replies, 20
            )
            replies[message["id"]] = message
        accepted = [rid for rid, m in replies.items() if m["identifier"] == "ack"]
        assert not accepted, f"{len(accepted)} commands that waited out the freeze were carried out: {accepted[:5]}"
        assert {m["code"] for m in replies.values()} == {"stale"}, list(replies.values())[:3]
        await asyncio.sleep(1.0)
        after = client.pose("robot1")
        assert after is not None
        turned = abs(math.remainder(after["yaw"] - before["yaw"], math.tau))
        assert turned < 0.01, f"the robot turned {turned:.3f} rad on commands that waited out a freeze"

        # A fresh command drives again at once: the relay recovered by itself.
        again = await client.request(drive("robot1", "y"))
        assert again["identifier"] == "ack", again
        await client.close()
    finally:
        if relay.returncode is None:
            relay.send_signal(signal.SIGCONT)
            relay.kill()
            await relay.wait()
