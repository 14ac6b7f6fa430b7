"""Alerts with a lifecycle (issue 30, item 2), on a real relay with real WebSocket clients and a real SQLite database:
raised by a finding made as or changed to an anomaly, acknowledged once by an operator (named, with a note, in the
database and the audit log), gone from every client's list, and the same after a restart."""

from __future__ import annotations

import asyncio
import dataclasses
import json
import sqlite3
import time
from pathlib import Path
from typing import Any

from relay.config import FleetConfig
from relay.inspection.records import AlertRecord, CaptureRecord
from relay.inspection.store import Store
from tests.conftest import RunningRelay
from tests.helpers.inspection import operator, relay_with_database
from tests.helpers.waiting import wait_until
from tests.wsclient import TestClient

LIVE_TARGET = {"identifier": "target/add", "target": "spot-1", "robot": "robot1", "u": 240, "v": 360}
#: Seconds: generous, for a loaded machine (502 alerts took over 30 s at load 19); never waited out when all is well.
WAIT = 120.0


def _capture(tmp_path: Path) -> None:
    """A database holding one capture of robot1 at the spill, for findings to be marked on."""
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "inspection-images") as store:
        capture = CaptureRecord("c-1", "robot1", 1795388500.0, 1.0, 7.5, 0.0, {"gas": 698.2}, None, "spill")
        store.add_capture(capture, None)


def _stored_alert(running: RunningRelay, alert_id: str) -> AlertRecord | None:
    """The alert as the relay's database holds it, read on a connection of the test's own."""
    store = running.relay.inspection.store
    assert store is not None
    with Store.open(store.name, store.images) as own:
        return own.alert(alert_id)


def _alerts(client: TestClient) -> dict[str, dict[str, Any]]:
    """The newest `alert` message of each alert this client received."""
    return {m["alert"]: m for _, m in client.messages if m["identifier"] == "alert"}


def _open(client: TestClient) -> set[str]:
    """The alerts this client lists: those whose newest message is not acknowledged."""
    return {a for a, m in _alerts(client).items() if m["acknowledged"] is None}


async def test_an_alert_acknowledged_by_one_operator_leaves_every_clients_list(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    await asyncio.to_thread(_capture, tmp_path)
    audit = tmp_path / "audit.jsonl"
    running = await relay_with_database(fleet_config, tmp_path, audit_log=str(audit))
    try:
        ana, ben = await operator(running), await operator(running)
        viewer = await TestClient.open(running.ws_url)
        await viewer.hello()
        assert (await ana.request({"identifier": "name", "name": "Ana"}))["identifier"] == "ack"
        marked = await ana.request(
            {"identifier": "finding/mark", "capture": "c-1", "status": "anomaly", "note": "drum leaking"}
        )
        assert marked["identifier"] == "ack", marked
        finding = await ana.wait_for(lambda m: m["identifier"] == "finding", WAIT)
        raised = await ben.wait_for(lambda m: m["identifier"] == "alert", WAIT)
        assert raised == {
            "identifier": "alert", "alert": raised["alert"], "kind": "anomaly", "robot": "robot1",
            "subject": finding["id"], "text": "Anomaly at Spill (robot1): drum leaking", "severity": "warning",
            "raised": raised["raised"], "acknowledged": None,
        }  # fmt: skip
        alert_id = raised["alert"]
        await viewer.wait_for(lambda m: m["identifier"] == "alert", WAIT)

        refused = await viewer.request({"identifier": "alert/ack", "alert": alert_id})
        assert refused["identifier"] == "error" and refused["code"] == "forbidden", refused
        unknown = await ben.request({"identifier": "alert/ack", "alert": "a-nope"})
        assert unknown["code"] == "bad_request" and "no alert 'a-nope'" in unknown["message"], unknown
        too_long = await ben.request({"identifier": "alert/ack", "alert": alert_id, "note": "x" * 201})
        assert too_long["code"] == "bad_request" and "at most 200 characters" in too_long["message"], too_long
        assert _open(ana) == _open(ben) == _open(viewer) == {alert_id}  # nothing refused changed anything

        acked = await ana.request({"identifier": "alert/ack", "alert": alert_id, "note": "valve closed"})
        assert acked["identifier"] == "ack", acked
        for client in (ana, ben, viewer):
            gone = await client.wait_for(lambda m: m["identifier"] == "alert" and m["acknowledged"] is not None, WAIT)
            assert gone["acknowledged"]["by"] == "Ana" and gone["acknowledged"]["note"] == "valve closed"
            assert _open(client) == set()
        again = await ben.request({"identifier": "alert/ack", "alert": alert_id})
        assert again["code"] == "bad_request", again
        assert f"alert {alert_id} was acknowledged already, by Ana" in again["message"]

        late = await operator(running)  # a client that connects now lists nothing
        assert (await late.request({"identifier": "findings/page", "limit": 1}))["identifier"] == "ack"
        assert _alerts(late) == {}
        stored = await asyncio.to_thread(_stored_alert, running, alert_id)
        assert stored is not None and (stored.acked_by, stored.ack_note) == ("Ana", "valve closed")
        for client in (ana, ben, viewer, late):
            await client.close()
    finally:
        await running.runner.cleanup()
    records = [json.loads(line) for line in audit.read_text().splitlines()]
    acks = [r for r in records if r["identifier"] == "alert/ack"]
    accepted = [r for r in acks if r["outcome"] == "accepted"]
    assert len(accepted) == 1 and accepted[0]["name"] == "Ana" and accepted[0]["role"] == "operator"
    assert accepted[0]["values"] == {"alert": alert_id, "note": "valve closed"}
    assert {r["code"] for r in acks if r["outcome"] == "refused"} == {"forbidden", "bad_request"}


async def test_a_finding_changed_to_an_anomaly_raises_one_alert(fleet_config: FleetConfig, tmp_path: Path) -> None:
    await asyncio.to_thread(_capture, tmp_path)
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        marked = await client.request({"identifier": "finding/mark", "capture": "c-1", "status": "ok"})
        assert marked["identifier"] == "ack", marked
        finding = await client.wait_for(lambda m: m["identifier"] == "finding", WAIT)
        for change in ({"status": "needs_review"}, {"status": "anomaly"}, {"status": "anomaly", "note": "worse"}):
            reply = await client.request({"identifier": "finding/update", "finding": finding["id"], **change})
            assert reply["identifier"] == "ack", reply
        alerts = list(_alerts(client).values())
        assert [(a["kind"], a["subject"], a["text"]) for a in alerts] == [
            ("anomaly", finding["id"], "Anomaly at Spill (robot1)")
        ]
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_alerts_outlive_a_restart_open_or_acknowledged(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """Raised through the one function every kind uses; the open one comes back to a client after the restart,
    the acknowledged one stays acknowledged."""
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        inspection = running.relay.inspection
        still = inspection.raise_alert(
            "threshold", "Past its limit at Leak (robot3): humidity 81.0 % (over 70 %)", robot="robot3",
            subject="c-7", severity="critical",
        )  # fmt: skip
        done = inspection.raise_alert("mission_aborted", "Mission Demo of robot1 aborted", robot="robot1")
        client = await operator(running)
        reply = await client.request({"identifier": "alert/ack", "alert": done.id})
        assert reply["identifier"] == "ack", reply
        await client.close()
    finally:
        await running.runner.cleanup()  # what waits to be written is written before the relay stops

    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        again = await client.request({"identifier": "alert/ack", "alert": done.id})
        assert again["code"] == "bad_request" and "acknowledged already" in again["message"], again
        # Sent after hello, before any reply: everything this client lists is here already.
        assert list(_alerts(client)) == [still.id]
        back = _alerts(client)[still.id]
        assert (back["kind"], back["robot"], back["subject"], back["severity"], back["acknowledged"]) == (
            "threshold", "robot3", "c-7", "critical", None,
        )  # fmt: skip
        assert back["text"] == still.text and back["raised"] == round(still.raised, 3)
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_an_aborted_mission_raises_an_alert(fleet_config: FleetConfig, tmp_path: Path) -> None:
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        started = await client.request(
            {"identifier": "mission/start", "robot": "robot1", "name": "Night round", "steps": [{"dwell": 60}]},
            timeout=WAIT,
        )
        assert started["identifier"] == "ack", started
        mission = await client.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running", WAIT)
        aborted = await client.request({"identifier": "mission/abort", "mission": mission["id"]})
        assert aborted["identifier"] == "ack", aborted
        alert = await client.wait_for(lambda m: m["identifier"] == "alert", WAIT)
        assert (alert["kind"], alert["robot"], alert["subject"], alert["severity"]) == (
            "mission_aborted", "robot1", mission["id"], "warning",
        )  # fmt: skip
        assert alert["text"].startswith("Mission Night round of robot1 aborted at step 1: aborted by "), alert
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_a_locked_database_delays_neither_an_alert_nor_an_estop(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    """Another process holds the SQLite write lock: the alert reaches every client at once and is stored once the
    lock is gone; an estop meanwhile is carried out and acknowledged while the lock is still held; an acknowledgement
    meanwhile is refused naming the database, and changes nothing."""
    running = await relay_with_database(fleet_config, tmp_path)
    blocker = sqlite3.connect(tmp_path / "inspection.sqlite", isolation_level=None, check_same_thread=False)
    try:
        client = await operator(running)
        blocker.execute("BEGIN IMMEDIATE")  # the write lock, as another process would hold it
        alert = running.relay.inspection.raise_alert("threshold", "Past its limit at Spill (robot1)", robot="robot1")
        await client.wait_for(lambda m: m["identifier"] == "alert" and m["alert"] == alert.id, WAIT)
        stopped = await client.request({"identifier": "estop"}, timeout=WAIT)
        assert stopped["identifier"] == "ack", stopped
        assert blocker.in_transaction  # still held: the estop did not wait for it
        refused = await client.request({"identifier": "alert/ack", "alert": alert.id}, timeout=WAIT)
        assert refused["code"] == "internal" and "is locked" in refused["message"], refused
        assert _open(client) == {alert.id}
        blocker.execute("ROLLBACK")
        stored = "SELECT id FROM alerts WHERE id = ?"  # read on a connection of the test's own
        await wait_until(lambda: bool(blocker.execute(stored, (alert.id,)).fetchall()), WAIT, "the alert stored")
        assert (await client.request({"identifier": "alert/ack", "alert": alert.id}))["identifier"] == "ack"
        await client.close()
    finally:
        blocker.close()
        await running.runner.cleanup()


async def test_readings_past_their_limits_raise_a_critical_alert_at_a_mission_capture(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    """robot1's gas limit set below anything it reads: a mission's capture step where it stands makes the rule's
    anomaly finding, and that raises one critical alert naming the target and the reading."""
    robot1 = fleet_config.robots[0]
    sensors = tuple(dataclasses.replace(s, warn_above=-1.0) if s.name == "gas" else s for s in robot1.sensors)
    robots = (dataclasses.replace(robot1, sensors=sensors), *fleet_config.robots[1:])
    running = await relay_with_database(dataclasses.replace(fleet_config, robots=robots), tmp_path)
    try:
        client = await operator(running)
        await client.wait_for(lambda m: m["identifier"] == "robot1/sensor" and m["name"] == "gas", WAIT)
        started = await client.request(
            {"identifier": "mission/start", "robot": "robot1", "steps": [{"capture": "spill"}]}, timeout=WAIT
        )
        assert started["identifier"] == "ack", started
        finding = await client.wait_for(lambda m: m["identifier"] == "finding" and m["status"] == "anomaly", WAIT)
        alert = await client.wait_for(lambda m: m["identifier"] == "alert", WAIT)
        assert (alert["kind"], alert["robot"], alert["subject"], alert["severity"]) == (
            "anomaly", "robot1", finding["id"], "critical",
        )  # fmt: skip
        assert alert["text"].startswith("Anomaly at Spill (robot1): gas "), alert
        assert alert["text"].endswith(" ppm (over -1 ppm)") and finding["source"] == "rule", alert
        # A target marked on the live image: its finding is to review, so the readings raise their own alert.
        deadline = time.monotonic() + WAIT
        while (added := await client.request(LIVE_TARGET, timeout=WAIT)).get("code") == "no_camera":
            assert time.monotonic() < deadline, added  # the sim's first frame is on its way
            await asyncio.sleep(0.2)
        assert added["identifier"] == "ack", added
        past = await client.wait_for(lambda m: m["identifier"] == "alert" and m["kind"] == "threshold", WAIT)
        assert (past["robot"], past["severity"]) == ("robot1", "critical") and past["subject"].startswith("c-")
        assert past["text"].startswith("Past its limit at spot-1 (robot1): gas "), past
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_memory_holds_the_newest_500_open_alerts_and_an_older_one_is_acknowledged_from_the_database(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        inspection = running.relay.inspection
        raised = [inspection.raise_alert("threshold", f"reading #{n}", robot="robot2") for n in range(502)]
        oldest = raised[0].id
        deadline = time.monotonic() + WAIT
        while await asyncio.to_thread(_stored_alert, running, raised[-1].id) is None:  # written in order
            assert time.monotonic() < deadline, "the alerts stored"
            await asyncio.sleep(0.1)
        client = await operator(running)
        reply = await client.request({"identifier": "alert/ack", "alert": oldest, "note": "old news"}, timeout=WAIT)
        assert reply["identifier"] == "ack", reply
        # After its hello, before any reply: the newest 500 open alerts, oldest first.
        sent = [m["alert"] for _, m in client.messages if m["identifier"] == "alert" and m["acknowledged"] is None]
        assert sent == [a.id for a in raised[2:]]
        gone = await client.wait_for(lambda m: m["identifier"] == "alert" and m["alert"] == oldest, WAIT)
        assert gone["acknowledged"]["note"] == "old news" and gone["text"] == "reading #0"
        stored = await asyncio.to_thread(_stored_alert, running, oldest)
        assert stored is not None and stored.acked_by is not None
        await client.close()
    finally:
        await running.runner.cleanup()
