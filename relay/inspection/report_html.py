"""The report as one self-contained HTML page (relay.inspection.report): the site, what the report covers and in
which time zone, the missions, a plan of the site with its rooms and the findings as numbered pins, and a table of
the findings (local time, room, target, readings with units and limits, status in words, who decided it, each
reading's trend over the target's last rounds as a sparkline with its limit, and the target's previous capture
beside this one: before and after, the region drawn on the after). Also the page that asks for a range
(``/report/range.html`` with no range).

Every text from the database or a file is escaped; the page sets no ``style`` attribute (the relay's
Content-Security-Policy allows only the embedded stylesheet, by its hash: relay.net.headers) and runs no script.
"""

from __future__ import annotations

import base64
import html
from datetime import time, timedelta
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from .report_rows import (
    Report,
    Row,
    iso_time,
    local_time,
    number,
    readable_date,
    readable_time,
    zone_label,
)
from .sparkline import SPARK_BOX, label_y, polyline, sparkline

if TYPE_CHECKING:
    from datetime import tzinfo

    from ..fleet.occupancy import OccupancyGrid
    from .records import CaptureRecord, MissionRecord
    from .store import Store

#: Also in report.css and the client's inspection_model.js. A change is purple, apart from the red of an anomaly
#: and the amber of a finding to review; a false alarm is grey, as something nobody needs to act on.
COLOURS = {
    "ok": "#2e9e4f", "anomaly": "#d62d20", "needs_review": "#e8a317", "changed": "#8e44ad", "false_alarm": "#7f8c8d",
}  # fmt: skip
OTHER_COLOUR = "#6b7280"  # a status this page does not know yet
#: The report's stylesheet, embedded (the report is one file); the relay's Content-Security-Policy allows exactly
#: this text by its hash (relay.net.headers), and the report sets no ``style`` attribute, which the policy would block.
STYLESHEET = (Path(__file__).resolve().parent / "report.css").read_text(encoding="utf-8")
PIXELS_PER_METRE = 50  # the plan: 1 px = 2 cm
MISSION_STATES = {"pending": "Pending", "running": "Running", "paused": "Paused", "done": "Done", "aborted": "Aborted"}
_PLURALS = {
    "anomaly": ("anomaly", "anomalies"), "ok": ("OK", "OK"), "needs_review": ("needs review", "need review"),
    "changed": ("changed since the last round", "changed since the last round"),
    "false_alarm": ("false alarm", "false alarms"),
}  # fmt: skip

esc = html.escape


def as_html(report: Report, store: Store, grid: OccupancyGrid | None) -> str:
    site, zone = report.site, report.site.zone
    title = f"{site.name}: inspection report"
    rows = "".join(_row(row, zone, store) for row in report.rows)
    empty = '<tr><td colspan="11">No findings.</td></tr>' if not report.rows else ""
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{esc(title)}</title><link rel="icon" href="data:,">
<style>{STYLESHEET}</style></head><body>
<h1>{esc(title)}</h1>
<dl class="facts">{_facts(report)}</dl>
<p>{_summary(report)}</p>
<h2>Missions</h2>{_missions(report.missions, zone)}
<h2>Plan</h2>{_plan_svg(report, grid)}
<h2>Findings</h2>
<table class="findings"><thead><tr><th>#</th><th>Status</th><th>Seen</th><th>Room</th><th>Target</th><th>Robot</th>
<th>Readings</th><th>Note</th><th>Decided by</th><th>Trend (last rounds)</th><th>Before / after</th></tr></thead>
<tbody>{rows}{empty}</tbody></table>
</body></html>
"""


def _facts(report: Report) -> str:
    scope, zone = report.scope, report.site.zone
    if scope.mission is not None:
        names = sorted({m.name for m in report.missions})
        covers = f"mission {esc(', '.join(names))} ({esc(scope.mission)})"
    else:
        assert scope.start is not None and scope.end is not None
        first, last = local_time(scope.start, zone), local_time(scope.end, zone)
        if first.time() == last.time() == time.min:  # whole days: name the last one, not the midnight after it
            covers = f"captures from {readable_date(first.date())} to {readable_date(last.date() - timedelta(days=1))}"
        else:
            covers = f"captures from {esc(readable_time(scope.start, zone))} to {esc(readable_time(scope.end, zone))}"
    seen = [row.time for row in report.rows]
    span = f"<dt>Captures</dt><dd>{_time(min(seen), zone)} to {_time(max(seen), zone)}</dd>" if seen else ""
    return (
        f"<dt>Site</dt><dd>{esc(report.site.name)}</dd><dt>Covers</dt><dd>{covers}</dd>{span}"
        f"<dt>Times</dt><dd>{esc(zone_label(zone, report.made))}</dd>"
        f"<dt>Made</dt><dd>{_time(report.made, zone)}</dd>"
    )


def _summary(report: Report) -> str:
    counts: dict[str, int] = {}
    for row in report.rows:
        counts[row.finding.status] = counts.get(row.finding.status, 0) + 1
    order = [*COLOURS, *sorted(set(counts) - set(COLOURS))]
    parts = []
    for status in order:
        n = counts.get(status, 0)
        if n:
            one, many = _PLURALS.get(status, (status.replace("_", " "),) * 2)
            parts.append(f"{n} {one if n == 1 else many}")
    total = len(report.rows)
    return f"{total} finding{'s' if total != 1 else ''}" + (": " + ", ".join(parts) if parts else "") + "."


def _time(t: float, zone: tzinfo | None) -> str:
    return f'<time datetime="{iso_time(t, zone)}">{esc(readable_time(t, zone))}</time>'


def _missions(missions: list[MissionRecord], zone: tzinfo | None) -> str:
    if not missions:
        return "<p>None.</p>"
    rows = "".join(
        f"<tr><td>{esc(m.robot)}</td><td>{esc(m.name)}<br><small>{esc(m.id)}</small></td>"
        f"<td>{esc(MISSION_STATES.get(m.state, m.state))}{': ' + esc(m.reason) if m.reason else ''}</td>"
        f"<td>{_time(m.created, zone)}</td><td>{_time(m.updated, zone)}</td><td>{m.current} of {len(m.steps)}</td></tr>"
        for m in missions
    )
    return (
        "<table><thead><tr><th>Robot</th><th>Mission</th><th>State</th><th>Started</th><th>Last change</th>"
        f"<th>Steps done</th></tr></thead><tbody>{rows}</tbody></table>"
    )


def _row(row: Row, zone: tzinfo | None, store: Store) -> str:
    f = row.finding
    readings = "<br>".join(
        f'<span class="{"past" if r.over else "within"}">{esc(r.text())}</span>' for r in row.readings
    )
    target = esc(row.target_name or f.target or "")
    return (
        f'<tr><td>{row.number}</td><td><span class="status {_status_class(f.status)}">{esc(row.status)}</span></td>'
        f"<td>{_time(row.time, zone)}</td><td>{esc(row.location) or '<small>outside the rooms</small>'}"
        f"<br><small>({f.x:.2f}, {f.y:.2f}) m</small></td><td>{target}</td><td>{esc(f.robot)}</td>"
        f"<td>{readings}</td><td>{esc(f.note)}</td><td>{esc(row.review(zone))}</td>{_trend_cell(row)}"
        f"{_image_cell(row, store, zone)}</tr>"
    )


def _status_class(status: str) -> str:
    return status if status in COLOURS else "other"


def _plan_svg(report: Report, grid: OccupancyGrid | None) -> str:
    """The site seen from above: the occupancy grid as an embedded image, the rooms outlined and named (in their
    lower left corner: targets stand along walls, most often the far ones), findings as numbered pins coloured by
    status, drawn over the names."""
    rooms = report.site.rooms
    if grid is not None:
        min_x, min_y, max_x, max_y = grid.bounds
    else:
        xs = [row.finding.x for row in report.rows] + [v for r in rooms for v in (r.min_x, r.max_x)] or [0.0]
        ys = [row.finding.y for row in report.rows] + [v for r in rooms for v in (r.min_y, r.max_y)] or [0.0]
        min_x, min_y, max_x, max_y = min(xs) - 1, min(ys) - 1, max(xs) + 1, max(ys) + 1
    scale = PIXELS_PER_METRE
    width, height = (max_x - min_x) * scale, (max_y - min_y) * scale
    image = ""
    if grid is not None:
        pixels = np.where(grid.occupied[::-1], 60, 245).astype(np.uint8)  # row 0 is the lowest y: flip for SVG
        ok, png = cv2.imencode(".png", pixels)
        if ok:
            image = (
                f'<image href="data:image/png;base64,{base64.b64encode(png.tobytes()).decode()}" x="0" y="0" '
                f'width="{width:.0f}" height="{height:.0f}" preserveAspectRatio="none" class="grid"/>'
            )
    outlines = "".join(
        f'<g class="room"><rect x="{(r.min_x - min_x) * scale:.1f}" y="{(max_y - r.max_y) * scale:.1f}" '
        f'width="{(r.max_x - r.min_x) * scale:.1f}" height="{(r.max_y - r.min_y) * scale:.1f}"/>'
        f'<text x="{(r.min_x - min_x) * scale + 12:.1f}" y="{(max_y - r.min_y) * scale - 14:.1f}">'
        f"{esc(r.title)}</text></g>"
        for r in rooms
    )
    pins = []
    for row in report.rows:
        f = row.finding
        px, py = (f.x - min_x) * scale, (max_y - f.y) * scale
        colour = COLOURS.get(f.status, OTHER_COLOUR)
        pins.append(
            f'<g><circle cx="{px:.1f}" cy="{py:.1f}" r="12" fill="{colour}" stroke="#fff" stroke-width="3"/>'
            f'<text x="{px:.1f}" y="{py + 5:.1f}" text-anchor="middle" font-size="14" fill="#fff">{row.number}</text>'
            f"<title>{row.number}. {esc(row.target_name or f.target or f.id)}: {esc(row.status)}"
            f"{' in ' + esc(row.location) if row.location else ''}</title></g>"
        )
    return (
        f'<svg viewBox="0 0 {width:.0f} {height:.0f}" width="100%" role="img" aria-label="plan of the site">'
        f"{image}{outlines}{''.join(pins)}</svg>"
    )


def _trend_cell(row: Row) -> str:
    """Each reading over the target's last rounds: a sparkline (relay.inspection.sparkline) with its limit dashed,
    and the values in words with the slope a round."""
    parts = []
    for trend in row.trends:
        if not trend.points:
            continue
        line = sparkline([(p.t, p.value) for p in trend.points], trend.limit)
        unit = f" {trend.unit}" if trend.unit else ""
        limit = ""
        if line.limit is not None and trend.limit is not None:
            limit = (
                f'<line class="limit" x1="{SPARK_BOX.pad:g}" x2="{SPARK_BOX.width - SPARK_BOX.pad:g}" '
                f'y1="{line.limit:.1f}" y2="{line.limit:.1f}"/>'
                f'<text x="{SPARK_BOX.pad:g}" y="{label_y(line.limit):.1f}">{esc(f"{trend.limit:g}{unit}")}</text>'
            )
        dots = "".join(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="2.5"/>' for x, y in line.points)
        values = ", ".join(number(p.value) for p in trend.points)
        slope = "" if trend.slope is None else f" ({trend.slope:+.1f}{unit} a round)"
        said = f"{trend.sensor} over the last {len(trend.points)} round{'s' * (len(trend.points) != 1)}"
        parts.append(
            f'<div class="trend{" toward" if trend.toward_limit else ""}">'
            f'<svg class="trend" viewBox="0 0 {SPARK_BOX.width:g} {SPARK_BOX.height:g}" width="{SPARK_BOX.width:g}" '
            f'height="{SPARK_BOX.height:g}" role="img" aria-label="{esc(said)}">{limit}'
            f'<polyline points="{polyline(line.points)}"/>{dots}</svg>'
            f"<small>{esc(trend.sensor)}: {esc(values)}{esc(unit)}{esc(slope)}</small></div>"
        )
    return f"<td>{''.join(parts) or '<small>no rounds</small>'}</td>"


def _image_cell(row: Row, store: Store, zone: tzinfo | None) -> str:
    """The target's previous capture (before) beside this one (after, with the finding's region)."""
    capture, before = row.capture, row.before
    after = _picture(capture, store, row.finding.region, f"capture of {row.target_name or row.finding.robot}")
    if after is None or capture is None:
        return "<td>no image</td>"
    earlier = _picture(before, store, None, f"previous capture of {row.target_name or row.finding.robot}")
    then = (
        f'<figure class="before">{earlier}<figcaption>Before: {_time(before.t, zone)}</figcaption></figure>'
        if earlier is not None and before is not None
        else '<figure class="before"><figcaption>No earlier capture</figcaption></figure>'
    )
    now = f'<figure class="after">{after}<figcaption>This round: {_time(capture.t, zone)}</figcaption></figure>'
    return f'<td class="images">{then}{now}</td>'


def _picture(
    capture: CaptureRecord | None, store: Store, region: tuple[tuple[int, int], ...] | None, label: str
) -> str | None:
    jpeg = store.image(capture.image) if capture is not None and capture.image else None
    if jpeg is None or capture is None:
        return None
    data = base64.b64encode(jpeg).decode()
    outline = ""
    if region:
        points = " ".join(f"{u},{v}" for u, v in region)
        outline = f'<polygon points="{points}" fill="rgba(255,220,0,0.25)" stroke="#ffdc00" stroke-width="3"/>'
    return (
        f'<svg viewBox="0 0 {capture.width} {capture.height}" width="200" role="img" aria-label="{esc(label)}">'
        f'<image href="data:image/jpeg;base64,{data}" width="{capture.width}" height="{capture.height}"/>{outline}'
        "</svg>"
    )


def range_form(
    name: str,
    zone: tzinfo | None,
    now: float,
    token: str | None,
    problem: str | None = None,
    asked: tuple[str | None, str | None] = (None, None),
) -> str:
    """The page that asks for a range: two dates (what was asked, else the last seven days) and a button per kind
    of report. It posts nothing: a GET to ``range.<kind>?from=...&to=...`` (relative: this page is
    ``/report/range.html``). The operator's token rides in a hidden field only when this page was opened with it;
    the reports themselves never carry it."""
    today = local_time(now, zone).date()
    start = asked[0] if asked[0] is not None else (today - timedelta(days=6)).isoformat()
    end = asked[1] if asked[1] is not None else today.isoformat()
    hidden = f'<input type="hidden" name="token" value="{esc(token)}">' if token else ""
    said = f'<p class="problem">{esc(problem)}</p>' if problem else ""
    buttons = "".join(
        f'<button type="submit" formaction="range.{kind}">{label}</button>'
        for kind, label in (
            ("html", "Report"), ("csv", "CSV"), ("json", "JSON"), ("workorders.csv", "Work orders (CSV)"),
            ("workorders.json", "Work orders (JSON)"),
        )
    )  # fmt: skip
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{esc(name)}: report of a period</title>
<link rel="icon" href="data:,"><style>{STYLESHEET}</style></head><body>
<h1>{esc(name)}: report of a period</h1>{said}
<form method="get" action="range.html" class="range">
<label>From <input type="date" name="from" value="{esc(start[:40])}" required></label>
<label>To (included) <input type="date" name="to" value="{esc(end[:40])}" required></label>{hidden}
<p>{buttons}</p></form>
<p><small>The findings whose capture was taken in those days, {esc(zone_label(zone, now))}.</small></p>
</body></html>
"""
