"""The inspection report: one self-contained HTML file (images embedded, a plan of the site with the findings as
pins, a table of findings), and the same findings as JSON and CSV.

    xr-relay report --mission ID [--database FILE_OR_URL] [--images DIR] [--config robots.yaml] [--out DIR]

``ID`` names a mission (``m-20261122-230112-ab12cd.robot1``) or the group a fleet mission started together
(``m-20261122-230112-ab12cd``: its robots' missions are reported together). The relay serves the same report at
``/report/<ID>.html`` (``.json``, ``.csv``).
"""

from __future__ import annotations

import argparse
import base64
import csv
import dataclasses
import html
import io
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from .records import CaptureRecord, FindingRecord, MissionRecord

if TYPE_CHECKING:
    from ..occupancy import OccupancyGrid
    from .store import Store

COLOURS = {"ok": "#2e9e4f", "anomaly": "#d62d20", "needs_review": "#e8a317"}  # also in report.css
#: The report's stylesheet, embedded (the report is one file); the relay's Content-Security-Policy allows exactly
#: this text by its hash (relay.headers), and the report sets no ``style`` attribute, which the policy would block.
STYLESHEET = (Path(__file__).resolve().parent / "report.css").read_text(encoding="utf-8")
CSV_FIELDS = (
    "finding",
    "status",
    "source",
    "mission",
    "robot",
    "target",
    "x",
    "y",
    "time",
    "note",
    "readings",
    "image",
)


#: A cell starting with one of these is read as a formula by spreadsheets (CSV injection: a note "=HYPERLINK(...)"
#: became a live link): such a cell gets a leading single quote, as OWASP advises, and is shown as typed.
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


@dataclass(frozen=True)
class Report:
    missions: list[MissionRecord]
    findings: list[FindingRecord]
    captures: dict[str, CaptureRecord]


class ReportError(ValueError):
    pass


def collect(store: Store, mission: str) -> Report:
    missions = [m for m in store.missions() if m.id == mission or m.id.startswith(mission + ".")]
    if not missions:
        known = ", ".join(sorted({m.id.split(".")[0] for m in store.missions()})[-10:]) or "none"
        raise ReportError(f"no mission {mission!r} in the database; recent missions: {known}")
    findings: list[FindingRecord] = []
    captures: dict[str, CaptureRecord] = {}
    for record in sorted(missions, key=lambda m: m.robot):
        findings += store.findings(mission=record.id)
        captures.update((c.id, c) for c in store.captures(record.id))
    return Report(sorted(missions, key=lambda m: m.robot), findings, captures)


def as_json(report: Report) -> str:
    return json.dumps(
        {
            "missions": [dataclasses.asdict(m) for m in report.missions],
            "findings": [dataclasses.asdict(f) for f in report.findings],
            "captures": [dataclasses.asdict(c) for c in report.captures.values()],
        },
        indent=2,
    )


def as_csv(report: Report) -> str:
    """The findings, one row each. Every text cell is neutralised (``_cell``); the numbers the report formats itself
    (x, y, time) stay numbers."""
    out = io.StringIO()
    writer = csv.writer(out)
    writer.writerow(CSV_FIELDS)
    for f in report.findings:
        capture = report.captures.get(f.capture)
        readings = "; ".join(f"{k}={v:g}" for k, v in (capture.readings if capture else {}).items())
        text = (f.id, f.status, f.source, f.mission or "", f.robot, f.target or "")
        writer.writerow(
            (*map(_cell, text), f"{f.x:.3f}", f"{f.y:.3f}", f.created, _cell(f.note), _cell(readings),
             _cell(capture.image if capture and capture.image else ""))
        )  # fmt: skip
    return out.getvalue()


def _cell(text: str) -> str:
    return "'" + text if text.startswith(FORMULA_STARTS) else text


def _plan_svg(report: Report, grid: OccupancyGrid | None) -> str:
    """The site seen from above: the occupancy grid as an embedded image, findings as pins (1 px = 2 cm)."""
    if grid is None:
        xs = [f.x for f in report.findings] or [0.0]
        ys = [f.y for f in report.findings] or [0.0]
        min_x, min_y, max_x, max_y = min(xs) - 2, min(ys) - 2, max(xs) + 2, max(ys) + 2
        image = ""
    else:
        min_x, min_y, max_x, max_y = grid.bounds
        pixels = np.where(grid.occupied[::-1], 60, 245).astype(np.uint8)  # row 0 is the lowest y: flip for SVG
        ok, png = cv2.imencode(".png", pixels)
        image = (
            f'<image href="data:image/png;base64,{base64.b64encode(png.tobytes()).decode()}" x="0" y="0" '
            f'width="{(max_x - min_x) * 50:.0f}" height="{(max_y - min_y) * 50:.0f}" preserveAspectRatio="none" '
            'class="grid"/>'
            if ok
            else ""
        )
    width, height = (max_x - min_x) * 50, (max_y - min_y) * 50
    pins = []
    for i, f in enumerate(report.findings, 1):
        px, py = (f.x - min_x) * 50, (max_y - f.y) * 50
        pins.append(
            f'<g><circle cx="{px:.1f}" cy="{py:.1f}" r="12" fill="{COLOURS[f.status]}" stroke="#fff" stroke-width="3"/>'
            f'<text x="{px:.1f}" y="{py + 5:.1f}" text-anchor="middle" font-size="14" fill="#fff">{i}</text>'
            f"<title>{html.escape(f.target or f.id)}: {f.status}</title></g>"
        )
    return (
        f'<svg viewBox="0 0 {width:.0f} {height:.0f}" width="100%" role="img" aria-label="plan of the site">'
        f"{image}{''.join(pins)}</svg>"
    )


def _image_cell(finding: FindingRecord, capture: CaptureRecord | None, store: Store) -> str:
    jpeg = store.image(capture.image) if capture and capture.image else None
    if jpeg is None:
        return "<td>no image</td>"
    data = base64.b64encode(jpeg).decode()
    region = ""
    if finding.region:
        points = " ".join(f"{u},{v}" for u, v in finding.region)
        region = f'<polygon points="{points}" fill="rgba(255,220,0,0.25)" stroke="#ffdc00" stroke-width="3"/>'
    assert capture is not None
    return (
        f'<td><svg viewBox="0 0 {capture.width} {capture.height}" width="320">'
        f'<image href="data:image/jpeg;base64,{data}" width="{capture.width}" height="{capture.height}"/>{region}'
        "</svg></td>"
    )


def as_html(report: Report, store: Store, grid: OccupancyGrid | None) -> str:
    rows = []
    for i, f in enumerate(report.findings, 1):
        capture = report.captures.get(f.capture)
        readings = "<br>".join(f"{html.escape(k)}: {v:.1f}" for k, v in (capture.readings if capture else {}).items())
        rows.append(
            f'<tr><td>{i}</td><td><span class="status {f.status}">{f.status}</span></td>'
            f"<td>{html.escape(f.target or '')}</td><td>{html.escape(f.robot)}</td>"
            f"<td>({f.x:.2f}, {f.y:.2f})</td><td>{readings}</td><td>{html.escape(f.note)}</td>"
            f"{_image_cell(f, capture, store)}</tr>"
        )
    missions = "".join(
        f"<li><b>{html.escape(m.robot)}</b>: {html.escape(m.id)}, {m.state}"
        f"{': ' + html.escape(m.reason) if m.reason else ''}, {m.current} of {len(m.steps)} steps</li>"
        for m in report.missions
    )
    title = html.escape(report.missions[0].name)
    counts = {s: sum(f.status == s for f in report.findings) for s in COLOURS}
    summary = ", ".join(f"{n} {s.replace('_', ' ')}" for s, n in counts.items() if n) or "no findings"
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{title}: inspection report</title><link rel="icon" href="data:,">
<style>{STYLESHEET}</style></head><body>
<h1>{title}</h1>
<p>{len(report.findings)} findings: {summary}.</p>
<ul>{missions}</ul>
<h2>Plan</h2>{_plan_svg(report, grid)}
<h2>Findings</h2>
<table><tr><th>#</th><th>status</th><th>target</th><th>robot</th><th>where (m)</th><th>readings</th><th>note</th>
<th>image</th></tr>{"".join(rows)}</table>
</body></html>
"""


def main(argv: Sequence[str] | None = None) -> int:
    from ..config import load_config
    from ..errors import ConfigError
    from ..occupancy import from_map_yaml
    from ..twin.facility import load_facility
    from .store import Store, StoreError, default_images

    parser = argparse.ArgumentParser(prog="xr-relay report", description=__doc__.split("\n\n")[0])
    parser.add_argument("--mission", required=True, help="a mission id, or the id a fleet mission's robots share")
    parser.add_argument("--database", default="xr-relay-inspection.sqlite", help="SQLite file or postgresql:// URL")
    parser.add_argument(
        "--images",
        help="capture images (default: beside a SQLite file, <name>-images; for PostgreSQL "
        "~/.local/share/xr-relay/images)",
    )
    parser.add_argument("--config", type=Path, default=Path("robots.yaml"), help="for the plan of the site")
    parser.add_argument("--out", type=Path, default=Path("."), help="directory for the .html, .json and .csv")
    args = parser.parse_args(argv)
    images = args.images or str(default_images(args.database))
    try:
        if "://" not in args.database and not Path(args.database).is_file():
            raise StoreError(f"{args.database}: no such database (start the relay with --database, or name it here)")
        store = Store.open(args.database, Path(images))
        report = collect(store, args.mission)
        grid = None
        try:
            config = load_config(args.config)
            if config.map is not None:
                grid = from_map_yaml(config.map)
            elif config.sim.world is not None:
                grid = load_facility(config.sim.world).grid
        except (ConfigError, ValueError, OSError) as exc:
            print(f"xr-relay report: no plan of the site ({exc})", file=sys.stderr)  # noqa: T201
        args.out.mkdir(parents=True, exist_ok=True)
        stem = args.out / f"report-{args.mission}"
        Path(f"{stem}.html").write_text(as_html(report, store, grid), encoding="utf-8")
        Path(f"{stem}.json").write_text(as_json(report), encoding="utf-8")
        Path(f"{stem}.csv").write_text(as_csv(report), encoding="utf-8")
        store.close()
    except (StoreError, ReportError, OSError) as exc:
        print(f"xr-relay report: {exc}", file=sys.stderr)  # noqa: T201
        return 2
    print(f"xr-relay report: {stem}.html, .json, .csv ({len(report.findings)} findings)")  # noqa: T201
    return 0
