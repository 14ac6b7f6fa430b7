"""The inspection report, for a plant manager: one self-contained HTML file (the site, each capture's local date
and time, rooms on the plan and in the table, readings with units and limits, statuses in words, who decided them,
images embedded), the same as JSON and CSV (times ISO 8601 with the offset), and the findings that need someone as
work orders (CSV and JSON, the fields an EAM import takes).

A report covers a ``Scope``: a mission (``m-20261122-230112-ab12cd.robot1``), the group a fleet mission started
together (``m-20261122-230112-ab12cd``: its robots' missions are reported together), or a time range (the findings
whose capture was taken in it). The relay serves it at ``/report/<ID>.<kind>`` and
``/report/range.<kind>?from=...&to=...`` (kinds: ``KINDS``); ``xr-relay report`` writes the same files
(relay.inspection.report_cli); docs/inspection.md.
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import io
import json
import os
import time
import zoneinfo
from collections.abc import Callable, Mapping
from datetime import tzinfo
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .records import CaptureRecord, FindingRecord, MissionRecord
from .report_html import as_html, range_form

# What a report is (report_rows), named here too: the server, the CLI and the service ask this module.
from .report_rows import RANGE as RANGE
from .report_rows import (
    WORK_ORDER_FIELDS,
    Limit,
    RangeError,
    Reading,
    Room,
    Row,
    SiteInfo,
    iso_time,
    number,
    parse_range,
    rows_of,
    work_orders,
)
from .report_rows import Report as Report
from .report_rows import Scope as Scope
from .trend import TREND_ROUNDS, Trend, series_of, trend_of

if TYPE_CHECKING:
    from ..config import FleetConfig
    from ..fleet.occupancy import OccupancyGrid
    from .store import Store

#: What ``/report/<name>.<kind>`` and ``xr-relay report`` make; the longest suffix first (``.workorders.csv`` is
#: not ``.csv``).
KINDS = ("workorders.csv", "workorders.json", "html", "json", "csv")
CONTENT_TYPES = {"html": "text/html", "json": "application/json", "csv": "text/csv"}
#: The most findings one report holds. The HTML embeds each finding's image (the demo's 480x480 JPEGs are about
#: 30 kB, 40 kB in base64): 1000 findings make a 40 MB page, about what a browser still opens comfortably; a
#: range holding more is refused with a message saying to narrow it, never cut short without saying so.
MAX_FINDINGS = 1000
CSV_FIELDS = (
    "finding",
    "status",
    "number",  # the finding's pin on the plan
    "source",
    "reviewed",
    "mission",
    "robot",
    "target",
    "target_name",
    "room",
    "x",
    "y",
    "time",
    "note",
    "readings",
    "image",
    "change",  # a change finding's score: the changed share of the view (0-1); empty for other findings
    "baseline",  # the capture a change finding was compared with
    "previous_capture",  # the target's previous capture (the baseline, else the one before with an image)
    "previous_image",
    "previous_readings",  # each reading at the target's previous round: "gas 284.2 ppm; ..."
    "trend",  # each reading's least-squares slope over the last rounds: "gas +83.2 ppm a round (3 rounds); ..."
)
#: A cell starting with one of these is read as a formula by spreadsheets (CSV injection: a note "=HYPERLINK(...)"
#: became a live link): such a cell gets a leading single quote, as OWASP advises, and is shown as typed.
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


class ReportError(ValueError):
    """Nothing to report under that name (an unknown mission)."""


class ReportRefused(ValueError):
    """A report that cannot be made as asked (a range holding too many findings); the message says what to do."""


def split_name(name: str) -> tuple[str, str] | None:
    """``m-1.robot1.workorders.csv`` -> ``("m-1.robot1", "workorders.csv")``; None for no known kind."""
    for kind in KINDS:
        stem = name.removesuffix("." + kind)
        if stem != name and 0 < len(stem) <= 128:
            return stem, kind
    return None


def content_type(kind: str) -> str:
    return CONTENT_TYPES[kind.rsplit(".", 1)[-1]]


def range_scope(start: str | None, end: str | None, zone: tzinfo | None) -> Scope:
    """The scope of ``?from=...&to=...`` (report_rows.parse_range; RangeError naming what is wrong)."""
    first, last = parse_range(start, end, zone)
    return Scope(start=first, end=last)


def asked_range(query: Mapping[str, str], kind: str, config: FleetConfig, now: float) -> Scope | tuple[int, str]:
    """What ``/report/range.<kind>?<query>`` asks for: its scope, or the answer to give instead of a report (for
    ``html``, the page asking for a range: 200 when none was given, 400 saying what is wrong with the one given;
    for the other kinds, 400 and the reason)."""
    name, zone = site_header(config)
    start, end = query.get("from"), query.get("to")
    if kind == "html" and start is None and end is None:
        return 200, range_form(name, zone, now, query.get("token"))
    try:
        return range_scope(start, end, zone)
    except RangeError as exc:
        if kind == "html":
            return 400, range_form(name, zone, now, query.get("token"), str(exc), (start, end))
        return 400, f"{exc}\n"


# -- what the report holds ----------------------------------------------------------------------------------------


def site_of(config: FleetConfig, store: Store | None = None, *, zone: str | None = None) -> SiteInfo:
    """The site as robots.yaml describes it: its name, zone (``zone``, else ``site.time_zone``, else local), the
    rooms of its scene file (``sim.world``), its sensors' units and limits, and its targets' names (the scene's
    hazards, then the database's). Reads files: not on the event loop."""
    from ..twin.facility import load_facility
    from .targets import facility_targets

    rooms: tuple[Room, ...] = ()
    targets: dict[str, str] = {}
    if config.sim.world is not None:
        try:
            facility = load_facility(config.sim.world)
        except (ValueError, OSError):  # the relay refuses to start on a bad scene file: this is the CLI's case
            pass
        else:
            rooms = tuple(facility.rooms)
            targets.update((t.id, t.name) for t in facility_targets(facility))
    if store is not None:
        targets.update((t.id, t.name) for t in store.targets())
    limits = {
        robot.name: {s.name: Limit(s.unit, s.warn_above, s.warn_below) for s in robot.sensors}
        for robot in config.robots
    }
    name, site_zone = site_header(config)
    return SiteInfo(name, zone_named(zone) if zone else site_zone, rooms, limits, targets)


def site_header(config: FleetConfig) -> tuple[str, tzinfo | None]:
    """The site's name (``site.name``, else its scene file's) and time zone (``site.time_zone``, else None: the
    relay's local zone). Reads no file."""
    source = config.sim.world or (Path(config.scene.url) if config.scene.url else None)
    name = config.site.name or (source.stem.replace("_", " ").capitalize() if source is not None else "The site")
    return name, zoneinfo.ZoneInfo(config.site.time_zone) if config.site.time_zone else local_zone()


@functools.cache  # read once: the zone a process runs in does not change under it
def local_zone() -> tzinfo | None:
    """The relay's own zone by its IANA name when it has one (``TZ=Europe/Berlin``, or /etc/localtime linking
    into the zone database), so that the report can name it; else None: Python's local time, which follows any
    ``TZ`` the C library reads (``TZ=CET-1CEST``) but has no name beyond its abbreviation."""
    name = os.environ.get("TZ", "").removeprefix(":")
    if not name and "TZ" not in os.environ:
        link = Path("/etc/localtime")
        target = str(link.resolve()) if link.is_symlink() else ""
        name = target.split("/zoneinfo/", 1)[1] if "/zoneinfo/" in target else ""
    try:
        return zoneinfo.ZoneInfo(name) if name else None
    except (ValueError, zoneinfo.ZoneInfoNotFoundError):
        return None


def collect(store: Store, scope: Scope, site: SiteInfo, *, now: float | None = None) -> Report:
    """The missions and findings a scope covers. ReportError for an unknown mission; ReportRefused for a range
    holding more than ``MAX_FINDINGS`` findings."""
    made = time.time() if now is None else now
    if scope.mission is not None:
        mission = scope.mission
        missions = sorted(
            (m for m in store.missions() if m.id == mission or m.id.startswith(mission + ".")), key=lambda m: m.robot
        )
        if not missions:
            known = ", ".join(sorted({m.id.split(".")[0] for m in store.missions()})[-10:]) or "none"
            raise ReportError(f"no mission {mission[:128]!r} in the database; recent missions: {known}")
        findings: list[FindingRecord] = []
        captures: dict[str, CaptureRecord] = {}
        for record in missions:
            findings += store.findings(mission=record.id)
            captures.update((c.id, c) for c in store.captures(record.id))
        return Report(scope, site, missions, with_history(store, rows_of(findings, captures, site), site), made)
    assert scope.start is not None and scope.end is not None
    pairs = store.findings_between(scope.start, scope.end, MAX_FINDINGS + 1)
    if len(pairs) > MAX_FINDINGS:
        raise ReportRefused(f"this range holds more than {MAX_FINDINGS} findings, the most one report holds: narrow it")
    ids = sorted({f.mission for f, _ in pairs if f.mission})
    found = [store.mission(i) for i in ids]
    missions = sorted((m for m in found if m is not None), key=lambda m: (m.created, m.robot))
    rows = rows_of([f for f, _ in pairs], {c.id: c for _, c in pairs}, site)
    return Report(scope, site, missions, with_history(store, rows, site), made)


def with_history(store: Store, rows: list[Row], site: SiteInfo) -> list[Row]:
    """``rows`` with what their targets were before: the previous capture (a change finding's baseline, else the
    target's newest earlier capture with an image whose change nobody marked a false alarm: what the change rule
    compares with) and each reading over the target's last ``TREND_ROUNDS`` rounds up to the row's capture. Read
    once per capture: the findings of one capture share them."""
    found: dict[str, tuple[CaptureRecord | None, tuple[Trend, ...]]] = {}
    out = []
    for row in rows:
        capture, target = row.capture, row.finding.target
        if capture is None or target is None:
            out.append(row)
            continue
        if capture.id not in found:
            before = store.last_capture_of(target, capture.t, capture.id)
            rounds = store.captures_of(target, capture.t, TREND_ROUNDS)
            trends = tuple(trend_of(r.sensor, series_of(rounds, r.sensor), r.limit) for r in row.readings)
            found[capture.id] = before, trends
        before, trends = found[capture.id]
        if row.finding.baseline is not None:
            before = store.capture(row.finding.baseline) or before
        out.append(dataclasses.replace(row, before=before, trends=trends))
    return out


# -- JSON and CSV -------------------------------------------------------------------------------------------------


def relay_images(origin: str) -> Callable[[str], str]:
    """Image URLs as the relay serves them from ``origin`` (``https://relay.example:8443``). They carry no token: a
    report is passed around, a token must not be; opening one needs the token or a relay that allows viewers."""
    return lambda sha: f"{origin.rstrip('/')}/captures/{sha}.jpg"


def as_json(report: Report, image_url: Callable[[str], str]) -> str:
    zone = report.site.zone
    return json.dumps(
        {
            "site": report.site.name,
            "time_zone": getattr(zone, "key", None) or "local",
            "made": iso_time(report.made, zone),
            "scope": _scope_json(report.scope, zone),
            "missions": [_mission_json(m, zone) for m in report.missions],
            "findings": [_finding_json(row, zone, image_url) for row in report.rows],
        },
        indent=2,
        ensure_ascii=False,
    )


def _mission_json(m: MissionRecord, zone: tzinfo | None) -> dict[str, Any]:
    return {
        "id": m.id, "name": m.name, "robot": m.robot, "state": m.state, "reason": m.reason, "steps": len(m.steps),
        "steps_done": m.current, "owner": m.owner, "created": iso_time(m.created, zone),
        "updated": iso_time(m.updated, zone),
    }  # fmt: skip


def _scope_json(scope: Scope, zone: tzinfo | None) -> dict[str, str]:
    if scope.mission is not None:
        return {"mission": scope.mission}
    assert scope.start is not None and scope.end is not None
    return {"from": iso_time(scope.start, zone), "to": iso_time(scope.end, zone)}


def _finding_json(row: Row, zone: tzinfo | None, image_url: Callable[[str], str]) -> dict[str, Any]:
    f, capture, before = row.finding, row.capture, row.before
    image = capture.image if capture is not None else None
    return {
        "id": f.id, "number": row.number, "status": f.status, "status_text": row.status, "source": f.source,
        "review": row.review(zone), "mission": f.mission, "robot": f.robot, "target": f.target,
        "target_name": row.target_name, "room": row.room.name if row.room else None,
        "room_title": row.room.title if row.room else None, "x": f.x, "y": f.y, "time": iso_time(row.time, zone),
        "created": iso_time(f.created, zone), "updated": iso_time(f.updated, zone), "note": f.note,
        "readings": [_reading_json(r, row.trend(r.sensor), zone) for r in row.readings],
        "capture": f.capture, "image": image, "image_url": image_url(image) if image else None,
        "region": f.region, "change": f.change, "baseline": f.baseline,
        "previous_capture": before.id if before else None,
        "previous_time": iso_time(before.t, zone) if before else None,
        "previous_image_url": image_url(before.image) if before and before.image else None,
    }  # fmt: skip


def _reading_json(r: Reading, trend: Trend | None, zone: tzinfo | None) -> dict[str, Any]:
    """A reading with its limits, the previous round's value and its trend: the least-squares ``slope`` (unit a
    round, null under 3 rounds) and the ``rounds`` behind it (time, value, mission), oldest first."""
    return {
        "sensor": r.sensor, "value": r.value, "unit": r.limit.unit, "warn_above": r.limit.warn_above,
        "warn_below": r.limit.warn_below, "past_limit": r.over, "text": r.text(),
        "previous": trend.previous if trend else None, "slope": trend.slope if trend else None,
        "toward_limit": trend.toward_limit if trend else False,
        "rounds": [{"time": iso_time(p.t, zone), "value": p.value, "mission": p.mission} for p in trend.points]
        if trend else [],
    }  # fmt: skip


def as_csv(report: Report, image_url: Callable[[str], str]) -> str:
    """The findings, one row each. Every text cell is neutralised (``_cell``); the numbers the report formats itself
    (x, y) and the times it writes stay as they are."""
    zone = report.site.zone
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(CSV_FIELDS)
    for row in report.rows:
        f, capture = row.finding, row.capture
        reviewed = iso_time(f.updated, zone) if f.updated > f.created else ""
        text = (f.id, row.status, str(row.number), f.source)
        place = (f.mission or "", f.robot, f.target or "", row.target_name, row.location)
        image = image_url(capture.image) if capture is not None and capture.image else ""
        writer.writerow(
            (*map(_cell, text), reviewed, *map(_cell, place), f"{f.x:.3f}", f"{f.y:.3f}", iso_time(row.time, zone),
             _cell(f.note), _cell("; ".join(r.text() for r in row.readings)), _cell(image),
             "" if f.change is None else f"{f.change:.4f}", _cell(f.baseline or ""), *_history_cells(row, image_url))
        )  # fmt: skip
    return out.getvalue()


def _history_cells(row: Row, image_url: Callable[[str], str]) -> tuple[str, str, str, str]:
    """The CSV's previous capture, its image, the previous round's readings and each reading's slope."""
    before = row.before
    unit = {r.sensor: f" {r.limit.unit}" if r.limit.unit else "" for r in row.readings}
    previous = "; ".join(
        f"{t.sensor} {number(t.previous)}{unit[t.sensor]}" for t in row.trends if t.previous is not None
    )
    slopes = "; ".join(
        f"{t.sensor} {t.slope:+.1f}{unit[t.sensor]} a round ({len(t.points)} rounds)"
        for t in row.trends
        if t.slope is not None
    )
    image = image_url(before.image) if before is not None and before.image else ""
    return _cell(before.id if before else ""), _cell(image), _cell(previous), _cell(slopes)


def work_orders_csv(report: Report, image_url: Callable[[str], str]) -> str:
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(WORK_ORDER_FIELDS)
    for order in work_orders(report.rows, report.site.zone, image_url):
        writer.writerow(
            _cell(v) if isinstance(v, str) else f"{v:.3f}" for v in dataclasses.astuple(order)
        )  # fmt: skip
    return out.getvalue()


def work_orders_json(report: Report, image_url: Callable[[str], str]) -> str:
    orders = [dataclasses.asdict(o) for o in work_orders(report.rows, report.site.zone, image_url)]
    return json.dumps({"site": report.site.name, "work_orders": orders}, indent=2, ensure_ascii=False)


def _cell(text: str) -> str:
    return "'" + text if text.startswith(FORMULA_STARTS) else text


def render(report: Report, kind: str, store: Store, grid: OccupancyGrid | None, image_url: Callable[[str], str]) -> str:
    """The report as ``kind`` (one of ``KINDS``)."""
    if kind == "html":
        return as_html(report, store, grid)
    writers = {
        "json": as_json, "csv": as_csv, "workorders.csv": work_orders_csv, "workorders.json": work_orders_json,
    }  # fmt: skip
    return writers[kind](report, image_url)


def zone_named(name: str) -> zoneinfo.ZoneInfo:
    """The IANA zone ``name``; ReportRefused naming ``--time-zone`` if the zone database has none."""
    try:
        return zoneinfo.ZoneInfo(name)
    except (ValueError, zoneinfo.ZoneInfoNotFoundError):
        raise ReportRefused(
            f"--time-zone: no time zone {name[:64]!r}; expected an IANA name such as Europe/Berlin"
        ) from None
