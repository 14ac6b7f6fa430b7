"""An estop that depends on nothing (issue #28): no database, no broadcast, no file parse, no pool may delay it.

Each test runs a real relay on loopback with the sim fleet, makes the relay busy with something an estop once
waited for, and measures the estop's ack and the robots' stop. 0.3 s is the promise; the margin a loaded CI
needs is in it (the ack takes ~10 ms on a quiet machine: bench/ measures it).
"""

from __future__ import annotations

import asyncio
import math
import secrets
import sqlite3
import subprocess
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import aiohttp
import orjson
import pytest
import websockets.asyncio.client

from relay.cli.options import Options
from relay.config import FleetConfig
from tests.conftest import LOAD_SLACK, ROOT, RunningRelay, relay_process, start_relay
from tests.helpers.postgres import running_postgres
from tests.helpers.waiting import wait_until
from tests.wsclient import TestClient

TOKEN = "op"
#: The promise: an estop's ack, and every robot's zero, within 0.3 s of the estop frame; a test adds what a loaded
#: machine may add (tests/conftest.py LOAD_SLACK). The figures before were 9.7-15 s or no ack at all; bench/
#: bench_estop.py holds the real number.
ESTOP_BOUND = 0.3 + LOAD_SLACK


async def operator(running: RunningRelay) -> TestClient:
    client = await TestClient.open(f"{running.ws_url}?token={TOKEN}")
    await client.hello()
    return client


async def start_demo(client: TestClient) -> list[str]:
    """The demo mission, one robot per room; returns the missions' ids once all three run."""
    reply = await client.request({"identifier": "mission/start", "file": "demo"}, timeout=30)
    assert reply["identifier"] == "ack", reply
    running: set[str] = set()
    while len(running) < 3:
        message = await client.wait_for(
            lambda m: m["identifier"] == "mission" and m["state"] == "running" and m["id"] not in running, 10
        )
        running.add(message["id"])
    return sorted(running)


async def health_when(running: RunningRelay, condition: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
    """/healthz once ``condition`` holds (the store's busy timeout is 5 s), or the last one after 20 s."""
    deadline = time.monotonic() + 20
    async with aiohttp.ClientSession() as http:
        while True:
            async with http.get(f"{running.url}/healthz") as response:
                health: dict[str, Any] = await response.json()
            if condition(health) or time.monotonic() > deadline:
                return health
            await asyncio.sleep(0.2)


async def timed_estop(client: TestClient, running: RunningRelay) -> tuple[dict[str, Any], float, float]:
    """Send an estop; returns its answer, the seconds to it, and the seconds until every sim robot was stopped."""
    world = running.relay.backend.world  # type: ignore[attr-defined]
    sent = time.monotonic()
    task = asyncio.ensure_future(client.request({"identifier": "estop"}, timeout=30))
    stopped = None
    while stopped is None and time.monotonic() - sent < 30:
        if all(r.follower is None and r.command == (0.0, 0.0) for r in world.robots.values()):
            stopped = time.monotonic() - sent
        await asyncio.sleep(0.005)
    reply = await task
    acked = next(t for t, m in client.messages if m.get("id") == reply["id"]) - sent
    assert stopped is not None
    return reply, acked, stopped


async def test_an_estop_does_not_wait_for_a_locked_database(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """Finding 1: with the SQLite file locked by another process mid-mission, the estop's ack came after 15.0 s
    (the missions' abort written one after another, 5 s busy timeout each), and every later frame of that operator
    waited behind it. Now the ack and the stop come at once; the missions, held, are stored once the lock is gone."""
    database = tmp_path / "inspection.sqlite"
    running = await start_relay(fleet_config, options=Options(token=TOKEN, database=str(database)))
    other = None
    try:
        client = await operator(running)
        ids = await start_demo(client)
        other = sqlite3.connect(database, isolation_level=None)  # another process's lock
        other.execute("BEGIN EXCLUSIVE")
        reply, acked, stopped = await timed_estop(client, running)
        assert reply["identifier"] == "ack", reply
        assert acked < ESTOP_BOUND, f"the estop's ack took {acked:.3f} s with the database locked"
        assert stopped < ESTOP_BOUND, f"the robots stopped {stopped:.3f} s after the estop"
        held = {m["id"] for _, m in client.messages if m["identifier"] == "mission" and "held" in m["reason"]}
        assert held == set(ids)  # every client is told at once, whatever the database does
        sent = time.monotonic()
        assert (await client.request({"identifier": "name", "name": "Ana"}))["identifier"] == "ack"
        assert time.monotonic() - sent < ESTOP_BOUND, "a later frame of the same operator waited"
        health = await health_when(running, lambda h: h["inspection_error"] is not None)
        assert health["status"] == "degraded" and "locked" in health["inspection_error"], health

        other.execute("ROLLBACK")
        other.close()
        other = None
        deadline = time.monotonic() + 30  # nothing is lost: the holds are written once the lock is gone
        states: dict[str, str] = {}
        while time.monotonic() < deadline:
            with sqlite3.connect(database) as reader:
                states = dict(reader.execute("SELECT id, reason FROM missions").fetchall())
            if all("held" in states.get(i, "") for i in ids):
                break
            await asyncio.sleep(0.2)
        assert all("held" in states.get(i, "") for i in ids), states
        await client.close()
    finally:
        if other is not None:
            other.close()
        await running.runner.cleanup()


@pytest.fixture
def own_postgres() -> Iterator[tuple[str, list[str]]]:
    """A PostgreSQL server of this test's own (it is stopped mid-test): its URL and the pg_ctl command line."""
    with running_postgres() as server:
        yield server


async def test_an_estop_with_postgresql_stopped_is_acknowledged_and_the_connection_stays(
    fleet_config: FleetConfig, tmp_path: Path, own_postgres: tuple[str, list[str]], caplog: pytest.LogCaptureFixture
) -> None:
    """Finding 1: with PostgreSQL stopped mid-mission, the estop closed the operator's connection with 1011 and no
    ack, with 7 tracebacks. Now: the ack within 0.3 s, the connection open, no traceback, /healthz names it."""
    url, pg_ctl = own_postgres
    options = Options(token=TOKEN, database=url, images=str(tmp_path / "images"))
    running = await start_relay(fleet_config, options=options)
    try:
        client = await operator(running)
        await start_demo(client)
        await asyncio.to_thread(subprocess.run, [*pg_ctl, "-m", "immediate", "stop"], capture_output=True)
        caplog.clear()
        reply, acked, stopped = await timed_estop(client, running)
        assert reply["identifier"] == "ack", reply
        assert acked < ESTOP_BOUND and stopped < ESTOP_BOUND, (acked, stopped)
        assert (await client.request({"identifier": "name", "name": "Ana"}, timeout=5))["identifier"] == "ack"
        assert client.closed_code is None, "the operator's connection was closed"
        health = await health_when(running, lambda h: h["inspection_error"] is not None)
        assert health["status"] == "degraded", health
        tracebacks = [r for r in caplog.records if r.exc_info is not None]
        assert not tracebacks, [r.getMessage() for r in tracebacks]
        await client.close()
    finally:
        await running.runner.cleanup()


async def other_operator_estop_during(
    running: RunningRelay, client: TestClient, busy: Callable[[], bool], timeout: float = 30
) -> tuple[dict[str, Any], float, float]:
    """Wait until ``busy()`` says the relay is at its busiest, then a timed estop from ``client``."""
    deadline = time.monotonic() + timeout
    while not busy():
        assert time.monotonic() < deadline, "the relay never got busy: the test measures nothing"
        await asyncio.sleep(0.01)
    return await timed_estop(client, running)


async def test_a_flood_of_targets_neither_delays_an_estop_nor_grows_without_bound(tmp_path: Path) -> None:
    """Finding 2: operators adding targets (8 connections, each under the rate limit, ~2300 targets) delayed another
    operator's estop to 9.7 s: every `target/add` re-sent the whole list, and nothing capped the count. Now each add
    sends only what changed, the site holds at most `inspection.max_targets` (2000), and the estop comes at once.
    The relay runs in a process of its own, so that the nine clients' reading is not counted as the relay's."""
    token = secrets.token_urlsafe(24)
    relay, base = await relay_process(
        "--backend", "sim", "--config", str(ROOT / "robots.yaml"), f"--token={token}", "--audit-log", "",
        "--database", str(tmp_path / "i.sqlite"),
    )  # fmt: skip
    url = base.replace("http", "ws") + f"/ws?token={token}"
    try:
        flooders = [await websockets.asyncio.client.connect(url, max_size=None) for _ in range(8)]
        refusals: list[str] = []
        sent_adds: dict[tuple[int, str], dict[str, Any]] = {}
        retried: list[str] = []

        async def drain(index: int, ws: Any) -> None:  # reads what the relay sends, parsing only the refusals
            async for data in ws:
                if '"error"' not in data[:40]:
                    continue
                error = orjson.loads(data)
                if error.get("code") == "busy":  # the store's pool was full: a bounded refusal; a client sends again
                    retried.append(error["message"])
                    await asyncio.sleep(0.1)
                    await ws.send(orjson.dumps(sent_adds[index, error["id"]]).decode())
                else:
                    refusals.append(error["message"])

        readers = [asyncio.ensure_future(drain(i, ws)) for i, ws in enumerate(flooders)]
        victim = await TestClient.open(url)
        await victim.hello()
        goal = await victim.request({"identifier": "robot1/goal_pose", "x": 3.0, "y": 8.0})  # robot1 drives
        assert goal["identifier"] == "ack", goal

        async def flood(index: int, ws: Any) -> None:
            for n in range(375):  # 8 x 375 = 3000 targets, each client at 40 a second (under its 60)
                add = {"identifier": "target/add", "id": f"a{n}", "target": f"t{index}-{n}", "x": 3.0, "y": 4.0}
                sent_adds[index, f"a{n}"] = add
                await ws.send(orjson.dumps(add).decode())
                await asyncio.sleep(1 / 40)

        floods = asyncio.gather(*(flood(i, ws) for i, ws in enumerate(flooders)))
        await asyncio.sleep(5.0)  # ~1600 targets sent: the relay is at its busiest
        sent = time.monotonic()
        reply = await victim.request({"identifier": "estop"}, timeout=30)
        acked = next(t for t, m in victim.messages if m.get("id") == reply["id"]) - sent
        assert reply["identifier"] == "ack", reply
        assert acked < ESTOP_BOUND, f"the estop's ack took {acked:.3f} s during the flood"
        await asyncio.sleep(ESTOP_BOUND)
        still = victim.pose("robot1")
        await asyncio.sleep(1.0)
        moved = victim.pose("robot1")
        # At most 5 cm from 0.3 s after the estop on (issue #27's bound; the sim brakes within its limits).
        assert still and moved and math.hypot(moved["x"] - still["x"], moved["y"] - still["y"]) < 0.05, (still, moved)
        await floods
        # The adds sent again after a full pool are answered.
        # Minutes on a loaded machine: a fresh clone's run beside other work had not answered them all in 120 s.
        try:
            await wait_until(lambda: len(refusals) + len(victim.targets()) >= 3000 + 3, 240, "every add answered")
        except AssertionError as exc:
            counts = f"{len(refusals)} refused, {len(victim.targets())} targets, {len(retried)} sent again"
            raise AssertionError(f"{exc}: {counts}") from None
        await asyncio.sleep(0.5)
        targets = victim.targets()
        assert len(targets) == 2000, len(targets)  # the cap; the deltas add up to what the relay holds
        assert len(refusals) == 3000 + 3 - 2000 and all("inspection.max_targets" in m for m in refusals)
        biggest = max(len(orjson.dumps(m)) for _, m in victim.messages if m["identifier"] == "targets_changed")
        assert biggest < 300, f"a change of one target took {biggest} bytes: the list is being re-sent"

        # An unknown target in a mission names a few of them, not the site's 2000 (a 139 kB error once).
        asked = [f"nowhere-{i}" for i in range(200)]  # the most a request may name
        error = await victim.request({"identifier": "mission/start", "targets": asked}, timeout=10)
        assert error["code"] == "bad_request" and "nowhere-0" in error["message"], error
        assert len(error["message"]) <= 400, len(error["message"])
        for ws in flooders:
            await ws.close()
        await asyncio.gather(*readers)
        await victim.close()
    finally:
        relay.kill()
        await relay.wait()


async def test_reading_a_big_kmz_mission_does_not_delay_an_estop(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """Finding 3: a KMZ mission of 6000 placemarks was parsed and assigned (quadratically) on the loop: another
    operator's estop waited 9.8 s. Now the file is read, parsed and assigned on the planning pool; this one has
    10 000 placemarks (the importer's limit), more than the site may hold: refused, and nothing added."""
    import simplekml  # type: ignore[import-untyped]

    from relay.inspection.kml import Georeference

    geo = Georeference(lat=48.137, lon=11.575)
    missions_dir = tmp_path / "missions"
    missions_dir.mkdir()

    def write() -> None:
        kml = simplekml.Kml()
        for i in range(10_000):
            kml.newpoint(name=f"Valve {i}", coords=[(geo.lon + (i % 100) * 1e-6, geo.lat + (i // 100) * 1e-6)])
        kml.savekmz(str(missions_dir / "rounds.kmz"))

    await asyncio.to_thread(write)
    options = Options(token=TOKEN, database=str(tmp_path / "i.sqlite"), missions_dir=missions_dir)
    running = await start_relay(replace(fleet_config, georeference=geo), options=options)
    try:
        lead, victim = await operator(running), await operator(running)
        before = dict(running.relay.inspection.targets)
        start = asyncio.ensure_future(lead.request({"identifier": "mission/start", "file": "rounds"}, timeout=60))
        pool = running.relay.inspection._planning  # the file is being read there
        reply, acked, stopped = await other_operator_estop_during(running, victim, lambda: pool.pending > 0)
        assert reply["identifier"] == "ack", reply
        assert acked < ESTOP_BOUND and stopped < ESTOP_BOUND, f"estop acked {acked:.3f} s, stopped {stopped:.3f} s"
        refused = await start
        assert refused["code"] == "bad_request" and "inspection.max_targets" in refused["message"], refused
        assert running.relay.inspection.targets == before  # all or nothing
        for client in (lead, victim):
            await client.close()
    finally:
        await running.runner.cleanup()


async def test_planning_six_long_missions_does_not_delay_an_estop(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """Finding 3: mission planning used asyncio's default pool: an estop waited up to 0.4 s while six 200-step
    missions were checked. Planning has its own bounded pool now: what does not fit is refused as `busy` at once."""
    robots = tuple(
        replace(fleet_config.robots[i % 3], name=f"robot{i + 1}", initial_pose=replace(
            fleet_config.robots[i % 3].initial_pose, y=1.5 + 0.6 * (i // 3)))
        for i in range(6)
    )  # fmt: skip
    running = await start_relay(
        replace(fleet_config, robots=robots), options=Options(token=TOKEN, database=str(tmp_path / "i.sqlite"))
    )
    try:
        leads = [await operator(running) for _ in range(6)]
        victim = await operator(running)
        # Across the facility and back, 30 times: every leg planned through the doors. About 6 s of planning each
        # on a loaded machine, two at a time: the pool is busy for as long as the estop takes, many times over
        # (200 legs each kept the test waiting a minute for answers after the estop).
        steps = [{"goto": {"x": 15.0 if k % 2 else 3.0, "y": 8.0 if k % 2 else 5.0}} for k in range(60)]
        starts = [
            asyncio.ensure_future(
                lead.request({"identifier": "mission/start", "robot": f"robot{i + 1}", "steps": steps}, timeout=120)
            )
            for i, lead in enumerate(leads)
        ]
        pool = running.relay.inspection._planning
        reply, acked, stopped = await other_operator_estop_during(running, victim, lambda: pool.pending >= 2)
        assert reply["identifier"] == "ack", reply
        assert acked < ESTOP_BOUND and stopped < ESTOP_BOUND, f"estop acked {acked:.3f} s, stopped {stopped:.3f} s"
        answers = await asyncio.gather(*starts)
        codes = sorted(a.get("code", a["identifier"]) for a in answers)
        # Planned missions meet the latch (`estopped`) or start before it; the pool's overflow is `busy` at once.
        assert set(codes) <= {"ack", "busy", "estopped"}, answers
        for client in [*leads, victim]:
            await client.close()
    finally:
        await running.runner.cleanup()
