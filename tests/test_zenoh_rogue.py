"""A rogue on the fleet's Zenoh network (docs/zenoh.md: the fleet's samples are not signed) against a real relay over
a real router on 127.0.0.1: what it sends is refused field by field like a client's frame, what it writes to the
log is bounded, and a lease token it declares holds nothing without heartbeats (issue 28, finding 6).

The rogue is a Zenoh client session of its own (tests/test_zenoh_backend.py has the router and the robots' side).
"""

from __future__ import annotations

import asyncio
import json
import logging
import re
import time
from collections.abc import AsyncIterator
from typing import Any

import orjson
import pytest

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.backends import zenoh as zenoh_backend  # noqa: E402
from relay.cli.options import Options, ZenohOptions  # noqa: E402
from relay.config import parse_config  # noqa: E402
from tests.conftest import RunningRelay, start_relay  # noqa: E402
from tests.helpers.zenoh import FLEET, ODOM, Router, until  # noqa: E402
from tests.wsclient import TestClient  # noqa: E402
from tests.zenoh_robots import key, odometry_by_hand  # noqa: E402

pytestmark = pytest.mark.slow

ESTOP = "xr_relay/estop"


class Rogue:
    """A Zenoh client session of the network that is no relay."""

    def __init__(self, session: Any) -> None:
        self.session = session
        self.tokens: list[Any] = []

    async def put(self, *samples: tuple[str, bytes]) -> None:
        """Put ``(key, payload)`` samples, in order, from a thread: blocking congestion control, so that every one
        reaches the relay (by default Zenoh drops what a congested link cannot take), and not on the loop that
        relay A runs on."""

        def send() -> None:
            for key_expr, payload in samples:
                self.session.put(key_expr, payload, congestion_control=zenoh.CongestionControl.BLOCK)

        await asyncio.to_thread(send)

    def token(self, key_expr: str) -> None:
        self.tokens.append(self.session.liveliness().declare_token(key_expr))


@pytest.fixture
async def rogue(router: Router) -> AsyncIterator[Rogue]:
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([router.endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = await asyncio.to_thread(zenoh.open, config)
    try:
        yield Rogue(session)
    finally:
        await asyncio.to_thread(session.close)


@pytest.fixture(autouse=True)
def _no_silent_key_warning(monkeypatch: pytest.MonkeyPatch) -> None:
    """beta's pose key has no publisher here: its warning 5 s after start is no line of the rogue's."""
    monkeypatch.setattr(zenoh_backend, "SILENT_AFTER", 1000.0)


async def relay_a(router: Router, fleet: str = FLEET) -> tuple[RunningRelay, TestClient]:
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,), relay_id="A"))
    running = await start_relay(parse_config(fleet, "fleet.yaml"), options=options)
    client = await TestClient.open(running.ws_url)
    await client.hello()
    return running, client


def refused(running: RunningRelay) -> Any:
    """Relay A's count of other relays' samples refused, by kind (/healthz's ``zenoh.fleet.refused``)."""
    health = running.relay.backend.health()["zenoh"]
    assert isinstance(health, dict)
    return health.get("fleet", {}).get("refused")


async def settled(running: RunningRelay, caplog: pytest.LogCaptureFixture, expected: dict[str, int]) -> list[str]:
    """Relay A's log once it has refused the ``expected`` samples, or as soon as it holds more than 10 lines (the
    relay before issue 28 wrote one per sample and counted none)."""
    deadline = time.monotonic() + 20
    while refused(running) != expected and len(relay_log(caplog)) <= 10:
        assert time.monotonic() < deadline, (refused(running), expected)
        await asyncio.sleep(0.05)
    await asyncio.sleep(0.2)  # a line about the last sample has been written
    return relay_log(caplog)


async def close(running: RunningRelay, client: TestClient) -> None:
    await client.close()
    await running.runner.cleanup()


def relay_log(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name.startswith("relay")]


async def heard(caplog: pytest.LogCaptureFixture, what: str) -> None:
    """Wait for the sentinel sample sent after the others (samples of one session arrive in order)."""
    await until(lambda: any(what in line for line in relay_log(caplog)), 10, f"the log line with {what!r}")


async def test_a_rogue_estop_of_huge_fields_reaches_no_client_latches_nothing_and_writes_little(
    router: Router,
    rogue: Rogue,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Measured before (issue 28, finding 6): a fleet-estop sample whose relay and by were 200 kB each latched every
    robot, reached every client as a 400 kB ``estop`` message and wrote 800 kB to the log. Now it is refused whole:
    no message to any client, nothing latched, one line of under 400 characters."""
    caplog.set_level(logging.INFO)
    running, client = await relay_a(router)
    try:
        start = len(client.messages)
        caplog.clear()
        huge = "x" * 200_000
        await rogue.put(
            (ESTOP, orjson.dumps({"relay": huge, "robot": None, "by": huge})),
            (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha", "by": huge})),
            # The sentinel: an estop of a robot relay A does not serve (named in its log, before and after).
            (ESTOP, orjson.dumps({"relay": "R", "robot": "sentinel9", "by": "c1"})),
        )
        await heard(caplog, "sentinel9")
        await asyncio.sleep(0.2)  # what the hop carried to the loop is done
        sizes = [len(orjson.dumps(message)) for _, message in client.messages[start:]]
        assert not [s for s in sizes if s > 1000], sizes
        assert all(message["identifier"] != "estop" for _, message in client.messages[start:])
        assert running.relay.control.latched == {}
        lines = relay_log(caplog)
        assert sum(map(len, lines)) < 1500 and max(map(len, lines)) < 400, lines
        assert refused(running)["estop"] == 2
        # alpha can still be driven.
        assert (await client.request({"identifier": "alpha/cmd_vel", "linear": 0.1, "angular": 0.0}))[
            "identifier"
        ] == "ack"
    finally:
        await close(running, client)


async def test_3000_malformed_samples_write_a_bounded_log_and_are_counted(
    router: Router,
    rogue: Rogue,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Measured before (issue 28, finding 6): 3000 malformed fleet estops wrote 3000 log lines (and two of their
    six shapes latched alpha). Now at most 10 lines a minute about other relays' samples (relay/logs/budget.py),
    nothing latched, and /healthz counts every sample refused (500 malformed heartbeats too)."""
    caplog.set_level(logging.INFO)
    running, client = await relay_a(router)
    try:
        caplog.clear()
        for i in range(500):
            await rogue.put(
                (ESTOP, b"{not json %d" % i),
                (ESTOP, orjson.dumps({"relay": i})),
                (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha", "by": i})),
                (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha", "by": "x" * (i + 65)})),
                (ESTOP, orjson.dumps({"relay": "R" * (i + 65), "robot": None})),
                (ESTOP, orjson.dumps({"relay": "R", "robot": [i]})),
                ("xr_relay/heartbeat/R", orjson.dumps({"relay": "R", "leases": [i]})),
            )
        expected = {"estop": 3000, "heartbeat": 500, "lease": 0}
        lines = await settled(running, caplog, expected)
        assert len(lines) <= 10, (len(lines), lines[:12])
        assert refused(running) == expected
        assert running.relay.control.latched == {}
    finally:
        await close(running, client)


async def test_a_rogue_lease_token_without_heartbeats_blocks_no_take_over(
    router: Router,
    rogue: Rogue,
) -> None:
    """Measured before (issue 28, finding 6): a liveliness token declared by any session on
    ``xr_relay/lease/alpha/<relay>/<client>`` refused every command and even a forced take-over of alpha, for as
    long as that session lived (60 s tried). A token now counts only while its relay's heartbeats list the lease."""
    rogue.token("xr_relay/lease/alpha/rogue/c1")
    running, client = await relay_a(router)  # starts after the token: it sees it through the history
    try:
        rogue.token("xr_relay/lease/beta/rogue/c2")
        await asyncio.sleep(1.0)  # the tokens cross loopback in milliseconds
        for robot in ("alpha", "beta"):
            reply = await client.request({"identifier": f"{robot}/lease", "force": True})
            assert reply["identifier"] == "ack", reply
            assert running.relay.fleet.status(robot, 0.0)["controller"] == client.latest["hello"]["client_id"]
    finally:
        await close(running, client)


async def test_a_lease_whose_relay_falls_silent_lapses_and_the_refusal_says_until_when(
    router: Router,
    rogue: Rogue,
) -> None:
    """A session that plays relay B (a token and heartbeats listing alpha) holds alpha: A's operator is refused,
    told until when; once its heartbeats stop (its session and token live on) the lease lapses after
    ``peer_lease_timeout`` (3 s here) and a forced take-over works. Before (issue 28) the token alone held alpha
    for as long as the session lived."""
    fleet = FLEET.replace("zenoh: {domain_id: 0}", "zenoh: {domain_id: 0, peer_lease_timeout: 3}")
    running, client = await relay_a(router, fleet)
    beating = True

    async def heartbeats() -> None:
        while beating:
            await rogue.put(("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": {"alpha": "c7"}})))
            await asyncio.sleep(0.3)

    task = asyncio.create_task(heartbeats())
    try:
        rogue.token("xr_relay/lease/alpha/B/c7")
        await until(lambda: running.relay.fleet.status("alpha", 0.0)["controller"], 5, "alpha held through B")
        assert running.relay.fleet.status("alpha", 0.0)["controller"] == "c7 through relay B"
        await asyncio.sleep(1.0)  # renewed meanwhile: still held
        reply = await client.request({"identifier": "alpha/lease", "force": True})
        assert reply["code"] == "leased", reply
        match = re.search(
            r"through relay B until (\d\d):(\d\d):(\d\d) UTC \(in (\d) s\) unless relay B renews it", reply["message"]
        )
        assert match is not None, reply
        until_s = int(match[1]) * 3600 + int(match[2]) * 60 + int(match[3])
        now_s = time.time() % 86400
        assert 1 <= (until_s - now_s) % 86400 <= 4 and 1 <= int(match[4]) <= 3, (reply, now_s)
        beating = False
        await task
        silent = time.monotonic()
        while (reply := await client.request({"identifier": "alpha/lease", "force": True}))["identifier"] != "ack":
            assert time.monotonic() - silent < 6, reply
            await asyncio.sleep(0.2)
        assert time.monotonic() - silent > 2.0  # not before the timeout (less the last heartbeat's age)
    finally:
        beating = False
        await task
        await close(running, client)


# -- hostile samples of every kind the relay reads from the network (the fuzz suite's Zenoh part) ------------------

HUGE = "x" * 200_000
#: (key, payload) put by the rogue; each is refused (counted as the kind named) and changes nothing.
HOSTILE_PUTS: list[tuple[str, bytes, str]] = [
    (ESTOP, b"", "estop"),
    (ESTOP, b"\xff\xfe", "estop"),
    (ESTOP, b'{"relay": "R", "robot": NaN}', "estop"),
    (ESTOP, b"[" * 2000 + b"]" * 2000, "estop"),
    (ESTOP, orjson.dumps([1, 2, 3]), "estop"),
    (ESTOP, orjson.dumps({"relay": HUGE}), "estop"),
    (ESTOP, orjson.dumps({"relay": ["R"], "robot": None}), "estop"),
    (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha", "by": -1}), "estop"),
    (ESTOP, orjson.dumps({"relay": "R", "robot": {"a": [[[]]]}}), "estop"),
    (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha\u202e", "by": "c1"}), "estop"),
    (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha", "by": "<script>"}), "estop"),
    (ESTOP, orjson.dumps({"relay": "R", "robot": "alpha", "by": "c1", "pad": HUGE}), "estop"),
    (ESTOP, orjson.dumps({"relay": "", "robot": None, "by": None}), "estop"),
    ("xr_relay/heartbeat/B", b"{", "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": {"alpha": 1.5e308}}), "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": {"alpha": -1}}), "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": {"alpha": HUGE}}), "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": {f"r{i}": "c" for i in range(300)}}), "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "C", "leases": {"alpha": "c1"}}), "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": None, "t": -5}), "heartbeat"),
    ("xr_relay/heartbeat/B", orjson.dumps({"relay": "B", "leases": {"alpha": "c1"}, "pad": HUGE}), "heartbeat"),
    ("xr_relay/heartbeat/" + "B" * 100, orjson.dumps({"relay": "B" * 100, "leases": {}}), "heartbeat"),
]
#: Lease tokens of the wrong shape (refused) or of the right shape with no heartbeat (holding nothing).
HOSTILE_TOKENS: list[tuple[str, bool]] = [
    ("xr_relay/lease/alpha/" + "R" * 20_000 + "/c1", True),
    ("xr_relay/lease/alpha/R/c1/extra", False),  # not under xr_relay/lease/*/*/*: never delivered
    ("xr_relay/lease/alpha/R", False),
    ("xr_relay/lease/9alpha/R/c1", True),
    ("xr_relay/lease/alpha/R/c~1", True),
    ("xr_relay/lease/alpha/R/c1", False),
    ("xr_relay/lease/beta/A/c1", False),  # under relay A's own name: ignored as its own
]


async def test_hostile_samples_of_every_kind_change_nothing_and_the_log_stays_bounded(
    router: Router,
    rogue: Rogue,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Table-driven (tests/test_zenoh_keys.py generates the decoders' inputs with hypothesis): huge strings, wrong
    types, JSON that is not, NaN and negative numbers, deep nesting, keys of the wrong shape, and the robots' side
    too (a body that is not CDR, types the relay does not expect, made-up keys under a robot's topic). Nothing is
    latched, no lease is held, no client gets a message over 1 kB, the relay still answers and reads a good pose,
    and the log gets at most 10 lines of under 400 characters."""
    caplog.set_level(logging.INFO)
    running, client = await relay_a(router)
    try:
        start = len(client.messages)
        caplog.clear()
        await rogue.put(*((key_expr, payload) for key_expr, payload, _ in HOSTILE_PUTS))
        for key_expr, _ in HOSTILE_TOKENS:
            rogue.token(key_expr)
        odom = key(*ODOM)
        good = odometry_by_hand(1_700_000_000, 0, "odom", "base_link", (4.0, 5.0, 0.0, 0.0, 0.0, 0.0, 1.0))
        for i, body in enumerate((b"", b"\x00\x01\x00\x00" + b"\xff" * 50, good[:40], HUGE.encode())):
            await rogue.put(
                (odom, body),
                (f"0/alpha/odom/nav_msgs::msg::dds_::Odometry_/{'H' * 5000}{i}", good[:20]),
                (f"0/alpha/odom/std_msgs::msg::dds_::String_{'S' * 5000}{i}/RIHS01_0", good),
            )
        expected = {"estop": 0, "heartbeat": 0, "lease": 0}
        for _, _, kind in HOSTILE_PUTS:
            expected[kind] += 1
        expected["lease"] = sum(refused for _, refused in HOSTILE_TOKENS)
        # The robots' side: a good pose after the bad ones is read.
        deadline = time.monotonic() + 10
        while client.pose("alpha") is None:
            assert time.monotonic() < deadline, "alpha's pose after the bad ones"
            await rogue.put((odom, good))
            await asyncio.sleep(0.1)
        lines = await settled(running, caplog, expected)
        assert len(lines) <= 10 and max(map(len, lines)) < 400, lines
        assert running.relay.control.latched == {}
        sizes = [len(orjson.dumps(message)) for _, message in client.messages[start:]]
        assert max(sizes) < 1000 and all(m["identifier"] != "estop" for _, m in client.messages[start:])
        for robot in ("alpha", "beta"):
            assert running.relay.control.peer is not None and running.relay.control.peer.held_elsewhere(robot) is None
            assert (await client.request({"identifier": f"{robot}/lease"}))["identifier"] == "ack"
        assert refused(running) == expected
    finally:
        await close(running, client)
