"""``xr-relay report``: the inspection report's five files (relay.inspection.report) from a database.

    xr-relay report (--mission ID | --from DATE --to DATE) [--database FILE_OR_URL] [--images DIR]
                    [--config robots.yaml] [--time-zone ZONE] [--origin URL] [--out DIR]

``ID`` names a mission or the group a fleet mission's robots share; ``--from``/``--to`` a time range (dates of the
site, ``--to`` included, or ISO 8601 date-times). Exit status 2 with a line naming what is wrong.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .report import (
    KINDS,
    RANGE,
    ReportError,
    ReportRefused,
    Scope,
    collect,
    range_scope,
    relay_images,
    render,
    site_of,
    zone_named,
)
from .report_rows import RangeError, SiteInfo, work_orders

if TYPE_CHECKING:
    from ..config import FleetConfig
    from ..fleet.occupancy import OccupancyGrid


def main(argv: Sequence[str] | None = None) -> int:
    from .store import Store, StoreError, default_images

    parser = argparse.ArgumentParser(
        prog="xr-relay report",
        description="The inspection report (HTML, JSON, CSV) and its work orders (CSV, JSON) as files.",
    )
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--mission", help="a mission id, or the id a fleet mission's robots share")
    which.add_argument("--from", dest="start", metavar="DATE", help="the first day (2026-11-01) or date-time")
    parser.add_argument("--to", dest="end", metavar="DATE", help="with --from: the last day (included) or date-time")
    parser.add_argument("--database", default="xr-relay-inspection.sqlite", help="SQLite file or postgresql:// URL")
    parser.add_argument(
        "--images",
        help="capture images (default: beside a SQLite file, <name>-images; for PostgreSQL "
        "~/.local/share/xr-relay/images)",
    )
    parser.add_argument("--config", type=Path, default=Path("robots.yaml"), help="the site: rooms, sensors, plan")
    parser.add_argument(
        "--time-zone", metavar="ZONE", help="IANA zone of the times (default: site.time_zone, else TZ / local)"
    )
    parser.add_argument(
        "--origin",
        metavar="URL",
        help="the relay's address as readers reach it (https://relay.example:8443), for image links; "
        "default: file:// links into the images directory",
    )
    parser.add_argument("--out", type=Path, default=Path("."), help="directory for the files")
    args = parser.parse_args(argv)
    if args.start is not None and args.end is None:
        parser.error("--from needs --to")
    if args.mission is not None and args.end is not None:
        parser.error("--to goes with --from, not with --mission")
    images = Path(args.images or default_images(args.database))
    try:
        if args.time_zone is not None:
            zone_named(args.time_zone)
        if "://" not in args.database and not Path(args.database).is_file():
            raise StoreError(f"{args.database}: no such database (start the relay with --database, or name it here)")
        config, grid = _site_config(args.config)
        with Store.open(args.database, images) as store:
            site = site_of(config, store, zone=args.time_zone) if config else _bare_site(args.time_zone)
            scope = Scope(mission=args.mission) if args.mission else range_scope(args.start, args.end, site.zone)
            report = collect(store, scope, site)
            if args.origin:
                image_url = relay_images(args.origin)
            else:
                root = images.absolute()
                image_url = lambda sha: (root / sha[:2] / f"{sha}.jpg").as_uri()  # noqa: E731
            args.out.mkdir(parents=True, exist_ok=True)
            stem = args.out / f"report-{scope.stem if args.mission else _range_stem(args.start, args.end)}"
            for kind in KINDS:
                Path(f"{stem}.{kind}").write_text(render(report, kind, store, grid, image_url), encoding="utf-8")
    except (StoreError, ReportError, ReportRefused, RangeError, OSError) as exc:
        print(f"xr-relay report: {exc}", file=sys.stderr)  # noqa: T201
        return 2
    findings, orders = len(report.rows), len(work_orders(report.rows, report.site.zone, image_url))
    print(  # noqa: T201
        f"xr-relay report: {stem}.html, .json, .csv, .workorders.csv, .workorders.json ({findings} "
        f"finding{'' if findings == 1 else 's'}, {orders} work order{'' if orders == 1 else 's'})"
    )
    return 0


def _bare_site(zone: str | None) -> SiteInfo:
    return SiteInfo("The site", zone_named(zone) if zone else None)


def _range_stem(start: str, end: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in f"{start}_to_{end}")
    return f"{RANGE}-{safe[:80]}"


def _site_config(path: Path) -> tuple[FleetConfig | None, OccupancyGrid | None]:
    """robots.yaml and the plan of the site; without them the report goes on with a line saying what it lacks."""
    from ..config import load_config
    from ..errors import ConfigError
    from ..fleet.occupancy import from_map_yaml
    from ..twin.facility import load_facility

    try:
        config = load_config(path)
    except ConfigError as exc:
        print(f"xr-relay report: no site description ({exc}): no rooms, units or plan", file=sys.stderr)  # noqa: T201
        return None, None
    try:
        if config.map is not None:
            return config, from_map_yaml(config.map)
        if config.sim.world is not None:
            return config, load_facility(config.sim.world).grid
    except (ConfigError, ValueError, OSError) as exc:
        print(f"xr-relay report: no plan of the site ({exc})", file=sys.stderr)  # noqa: T201
    return config, None
