"""Alerts to webhooks (issue 30, item 6), against a real aiohttp receiver on a loopback port: signed requests that a
verifier written here from the documented rule accepts (and refuses once tampered with or too old), retries after
5xx and connection errors with the backoff driven by hand, none after a 4xx, a bounded queue, every attempt recorded
in a real database (SQLite and PostgreSQL), and a real relay delivering an operator's anomaly and its
acknowledgement once each, its secret in no log, no row and no answer."""

from __future__ import annotations

import asyncio
import dataclasses
import hashlib
import hmac
import logging
import time
from collections import deque
from collections.abc import AsyncIterator, Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from pathlib import Path
from typing import Any, TypeVar

import aiohttp
import orjson
import pytest
from aiohttp import web

from relay.cli.options import Options
from relay.config import FleetConfig, Webhook
from relay.inspection.messages import alert_message
from relay.inspection.records import AlertRecord, DeliveryRecord
from relay.inspection.store import Store
from relay.inspection.webhooks import Webhooks
from tests.conftest import start_relay
from tests.helpers.inspection import TOKEN, operator
from tests.helpers.postgres import running_postgres
from tests.helpers.waiting import wait_until

T = TypeVar("T")
SECRET = "s3cret-for-the-receiver-only"
WAIT = 30.0  # seconds: generous for a loaded machine; never waited out when all is well


def verify(secret: str, headers: Any, body: bytes, now: float) -> bool:
    """The receiver's check, written from docs/inspection.md: a fresh timestamp, and the HMAC of "<ts>.<body>"."""
    timestamp, signature = headers.get("X-XR-Relay-Timestamp", ""), headers.get("X-XR-Relay-Signature", "")
    if not timestamp.isdigit() or abs(now - int(timestamp)) > 300:
        return False
    expected = hmac.new(secret.encode(), timestamp.encode() + b"." + body, hashlib.sha256).hexdigest()
    return hmac.compare_digest(signature, "sha256=" + expected)


class Receiver:
    """A loopback HTTP endpoint answering each POST with the next of ``answers`` (then 200), keeping what it got."""

    def __init__(self) -> None:
        self.answers: deque[int] = deque()
        self.got: list[tuple[Any, bytes]] = []
        self.url = ""

    async def handle(self, request: web.Request) -> web.Response:
        self.got.append((request.headers.copy(), await request.read()))
        return web.Response(status=self.answers.popleft() if self.answers else 200)

    def events(self) -> list[tuple[str, str]]:
        return [(orjson.loads(body)["event"], orjson.loads(body)["alert"]["alert"]) for _, body in self.got]


@pytest.fixture
async def receiver() -> AsyncIterator[Receiver]:
    got = Receiver()
    app = web.Application()
    app.router.add_post("/hook", got.handle)
    runner = web.AppRunner(app)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    host, port = runner.addresses[0][:2]
    got.url = f"http://{host}:{port}/hook"
    try:
        yield got
    finally:
        await runner.cleanup()


class HandMovedTime:
    """The webhooks' sleep and monotonic clock: a sleep returns at once and moves the clock by what it asked."""

    def __init__(self) -> None:
        self.now = 0.0
        self.pauses: list[float] = []

    async def sleep(self, seconds: float) -> None:
        self.pauses.append(seconds)
        self.now += seconds
        await asyncio.sleep(0)

    def monotonic(self) -> float:
        return self.now


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.timeout(900))])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Store]:
    """Where the deliveries are recorded: a SQLite file, or a PostgreSQL server of this test's own."""
    if request.param == "sqlite":
        with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "images") as opened:
            yield opened
        return
    with running_postgres() as (url, _), Store.open(url, tmp_path / "images") as opened:
        yield opened


def _alert(kind: str = "anomaly", alert_id: str = "a-1") -> AlertRecord:
    return AlertRecord(alert_id, kind, "robot2", "f-1", "Anomaly at Spill (robot2): gas 312.0 ppm", "critical", 5.0)


#: The test's store is used from this one thread only, as the relay uses its own (a connection is not thread-safe).
_DB = ThreadPoolExecutor(1, thread_name_prefix="test-store")


async def _db(work: Callable[[], T]) -> T:
    return await asyncio.get_running_loop().run_in_executor(_DB, work)


def _hooks(store: Store, *webhooks: Webhook, time_: HandMovedTime, **limits: Any) -> Webhooks:
    async def record(delivery: DeliveryRecord) -> None:
        await _db(lambda: store.add_delivery(delivery))

    return Webhooks(webhooks, record, sleep=time_.sleep, monotonic=time_.monotonic, **limits)


async def _rows(store: Store, done: Callable[[list[DeliveryRecord]], bool], what: str) -> list[DeliveryRecord]:
    """The recorded attempts, newest first, once ``done`` holds of them (polled every 50 ms, up to WAIT s)."""
    deadline = time.monotonic() + WAIT
    while not done(found := await _db(lambda: store.deliveries(100))):
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {WAIT} s waiting for {what}")
        await asyncio.sleep(0.05)
    return found


async def _outcomes(store: Store, count: int) -> list[tuple[int, int | None, str]]:
    """(attempt, status, outcome) of the ``count`` recorded attempts, oldest first, once there are that many."""
    found = await _rows(store, lambda rows: len(rows) >= count, f"{count} recorded deliveries")
    return [(d.attempt, d.status, d.outcome) for d in reversed(found)]


async def test_a_signed_alert_is_retried_after_two_5xx_and_delivered_once(receiver: Receiver, store: Store) -> None:
    time_ = HandMovedTime()
    hooks = _hooks(store, Webhook(receiver.url, SECRET), time_=time_)
    receiver.answers.extend([500, 503])
    hooks.start()
    try:
        hooks.notify("alert.raised", alert_message(_alert()))
        assert await _outcomes(store, 3) == [(1, 500, "retrying"), (2, 503, "retrying"), (3, 200, "delivered")]
    finally:
        await hooks.stop()
    assert time_.pauses == [1.0, 2.0]  # the backoff, moved by hand
    assert len(receiver.got) == 3 and len({body for _, body in receiver.got}) == 1  # the same event each time
    headers, body = receiver.got[-1]
    assert verify(SECRET, headers, body, time.time())
    assert orjson.loads(body) == {
        "event": "alert.raised",
        "alert": {k: v for k, v in alert_message(_alert()).items() if k != "identifier"},
    }
    # Tampered with, signed with another secret, or replayed six minutes later: refused.
    assert not verify(SECRET, headers, body.replace(b"312.0", b"31.2"), time.time())
    assert not verify("another-secret-of-the-same-size", headers, body, time.time())
    assert not verify(SECRET, headers, body, int(headers["X-XR-Relay-Timestamp"]) + 360)
    rows = await _db(lambda: store.deliveries(10))
    assert {d.endpoint for d in rows} == {receiver.url} and all(SECRET not in repr(d) for d in rows)


async def test_a_4xx_is_not_retried(receiver: Receiver, store: Store) -> None:
    time_ = HandMovedTime()
    hooks = _hooks(store, Webhook(receiver.url, SECRET), time_=time_)
    receiver.answers.append(422)
    hooks.start()
    try:
        hooks.notify("alert.raised", alert_message(_alert()))
        assert await _outcomes(store, 1) == [(1, 422, "refused")]
        hooks.notify("alert.raised", alert_message(_alert(alert_id="a-2")))  # the next event goes on as usual
        assert (await _outcomes(store, 2))[1] == (1, 200, "delivered")
    finally:
        await hooks.stop()
    assert time_.pauses == [] and len(receiver.got) == 2
    assert hooks.health()["endpoints"][0]["failed"] == 1


async def test_an_unreachable_endpoint_is_tried_five_times_within_the_budget(tmp_path: Path) -> None:
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "images") as store:
        closed = web.Application()
        runner = web.AppRunner(closed)
        await runner.setup()
        site = web.TCPSite(runner, "127.0.0.1", 0)
        await site.start()
        port = runner.addresses[0][1]
        await runner.cleanup()  # nothing listens there now: every attempt is refused
        url = f"http://user:pa55word@127.0.0.1:{port}/hook?token=t0ken"
        for budget, pauses in ((120.0, [1.0, 2.0, 4.0, 8.0]), (5.0, [1.0, 2.0])):
            time_ = HandMovedTime()
            hooks = _hooks(store, Webhook(url, SECRET), time_=time_, budget=budget)
            hooks.start()
            try:
                alert = f"a-{budget:g}"
                hooks.notify("alert.raised", alert_message(_alert(alert_id=alert)))
                await _rows(store, partial(_gave_up, alert), f"giving up {alert}")
            finally:
                await hooks.stop()
            assert time_.pauses == pauses and hooks.health()["endpoints"][0]["failed"] == 1
            tried = [d for d in await _db(lambda: store.deliveries(100)) if d.alert == alert]
            assert [d.outcome for d in reversed(tried)] == ["retrying"] * len(pauses) + ["failed"]
            assert all(d.status is None and "ClientConnectorError" in d.detail for d in tried)
        # The endpoint is named without its user, password or query, in rows and in what /healthz shows.
        rows = await _db(lambda: store.deliveries(100))
        assert {d.endpoint for d in rows} == {f"http://127.0.0.1:{port}/hook"}
        assert "pa55word" not in repr(hooks.health()) and "t0ken" not in repr(rows)


def _gave_up(alert: str, rows: list[DeliveryRecord]) -> bool:
    return any(d.alert == alert and d.outcome == "failed" for d in rows)


async def test_a_full_queue_drops_the_oldest_and_endpoints_get_the_events_they_want(
    receiver: Receiver, tmp_path: Path
) -> None:
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "images") as store:
        time_ = HandMovedTime()
        everything = Webhook(receiver.url, SECRET)
        acknowledgements = Webhook(receiver.url + "?only=acks", SECRET, ("alert.acknowledged",))
        hooks = _hooks(store, everything, acknowledgements, time_=time_, queue_size=2)
        for n in range(3):  # not started yet: they wait, and the third pushes the first out
            hooks.notify("alert.raised", alert_message(_alert("threshold", f"a-{n}")))
        acked = dataclasses.replace(_alert("threshold", "a-1"), acked_by="Ana", acked_at=6.0)
        hooks.notify("alert.acknowledged", alert_message(acked))
        assert [e["dropped"] for e in hooks.health()["endpoints"]] == [2, 0]
        hooks.start()
        try:
            await wait_until(lambda: len(receiver.got) == 3, WAIT, "three deliveries")
        finally:
            await hooks.stop()
    assert sorted(receiver.events()) == [("alert.acknowledged", "a-1"), ("alert.acknowledged", "a-1"),
                                         ("alert.raised", "a-2")]  # fmt: skip
    assert all(verify(SECRET, headers, body, time.time()) for headers, body in receiver.got)


async def test_a_relay_delivers_an_anomaly_and_its_acknowledgement_once_and_never_shows_its_secret(
    fleet_config: FleetConfig, tmp_path: Path, receiver: Receiver, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG)
    inspection = dataclasses.replace(fleet_config.inspection, webhooks=(Webhook(receiver.url, SECRET),))
    config = dataclasses.replace(fleet_config, inspection=inspection)
    options = Options(token=TOKEN, database=str(tmp_path / "inspection.sqlite"))
    running = await start_relay(config, options=options)
    try:
        client = await operator(running)
        raised = running.relay.inspection.raise_alert("threshold", "Past its limit at Leak (robot3)", robot="robot3")
        await wait_until(lambda: len(receiver.got) == 1, WAIT, "the raised alert at the receiver")
        reply = await client.request({"identifier": "alert/ack", "alert": raised.id, "note": "seen"})
        assert reply["identifier"] == "ack", reply
        await wait_until(lambda: len(receiver.got) == 2, WAIT, "the acknowledgement at the receiver")
        assert receiver.events() == [("alert.raised", raised.id), ("alert.acknowledged", raised.id)]
        assert all(verify(SECRET, headers, body, time.time()) for headers, body in receiver.got)
        assert orjson.loads(receiver.got[1][1])["alert"]["acknowledged"]["note"] == "seen"
        deadline = time.monotonic() + WAIT
        while len(await running.relay.inspection.deliveries(10)) < 2:  # read on the relay's store thread
            assert time.monotonic() < deadline, "both attempts recorded"
            await asyncio.sleep(0.05)
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{running.url}/webhooks/deliveries?token={TOKEN}") as response:
                assert response.status == 200
                text = await response.text()
            async with http.get(f"{running.url}/webhooks/deliveries?token=wrong") as refused:
                assert refused.status == 404
            async with http.get(f"{running.url}/healthz") as health:
                endpoints = (await health.json())["webhooks"]["endpoints"]
        shown = orjson.loads(text)
        assert [(d["event"], d["alert"], d["attempt"], d["status"], d["outcome"]) for d in shown["deliveries"]] == [
            ("alert.acknowledged", raised.id, 1, 200, "delivered"),
            ("alert.raised", raised.id, 1, 200, "delivered"),
        ]
        assert (
            endpoints
            == shown["endpoints"]
            == [
                {"endpoint": receiver.url, "queued": 0, "dropped": 0, "delivered": 2, "failed": 0, "last_failure": None}
            ]
        )
        assert SECRET not in text
        await client.close()
    finally:
        await running.runner.cleanup()
    assert len(receiver.got) == 2  # once each
    assert SECRET not in caplog.text


def test_delivery_attempts_are_kept_90_days_and_at_most_a_bounded_count(
    store: Store, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A webhook that fails for months, or an alert storm, does not grow the database without bound: attempts older
    than 90 days go, and past the row cap the oldest go, as each new one is written."""
    from relay.inspection import alert_store

    def attempt(n: int, t: float) -> DeliveryRecord:
        return DeliveryRecord(f"d-{n}", "http://127.0.0.1:9/hook", "alert.raised", "a-1", 1, t, None, "failed", "x")

    now = time.time()
    store.add_delivery(attempt(0, now - 91 * 86400))
    store.add_delivery(attempt(1, now - 89 * 86400))
    assert [d.id for d in store.deliveries(10)] == ["d-1", "d-0"]  # both kept until a newer attempt is written
    store.add_delivery(attempt(2, now))
    assert [d.id for d in store.deliveries(10)] == ["d-2", "d-1"]
    monkeypatch.setattr(alert_store, "MOST_DELIVERIES", 4)
    for n in range(3, 9):
        store.add_delivery(attempt(n, now + n))
    assert [d.id for d in store.deliveries(10)] == ["d-8", "d-7", "d-6", "d-5"]
