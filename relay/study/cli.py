"""``xr-relay study check|export``: a study file checked, and its runs written as tidy CSV and an HTML summary."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import ConfigError
from .results import summarise, tidy_csv
from .run import StudyError
from .store import RunStore
from .study_file import load_study
from .summary_html import summary_html

#: Where the relay keeps the studies' runs unless told otherwise (one folder per study).
DEFAULT_RUNS = "xr-relay-studies"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="xr-relay study", description=__doc__)
    sub = parser.add_subparsers(dest="action", required=True)
    check = sub.add_parser("check", help="read a study file and say its participants' orders, or what is wrong")
    check.add_argument("study", type=Path)
    export = sub.add_parser("export", help="the runs as tidy CSV (one row per measure) and an HTML summary")
    export.add_argument("study", type=Path)
    export.add_argument("--runs", type=Path, default=Path(DEFAULT_RUNS), help=f"default ./{DEFAULT_RUNS}")
    export.add_argument("--out", type=Path, default=Path("."), help="the folder the two files go to (default .)")
    args = parser.parse_args(argv)
    try:
        study = load_study(args.study)
        if args.action == "check":
            for participant, order in study.orders:
                print(f"{participant}: {', '.join(order)}")  # noqa: T201
            size = f"{len(study.participants)} participants, {len(study.tasks)} tasks"
            print(f"{study.name}: {size}; valid")  # noqa: T201
            return 0
        runs = RunStore(args.runs, study).runs()
        rows = [row for run in runs for row in run.rows()]
        args.out.mkdir(parents=True, exist_ok=True)
        csv_path, html_path = args.out / f"{study.name}.csv", args.out / f"{study.name}.html"
        csv_path.write_text(tidy_csv(rows), encoding="utf-8")
        conditions = [c.name for c in study.conditions]
        html_path.write_text(summary_html(study.name, summarise(rows, conditions), len(runs)), encoding="utf-8")
        print(f"{len(rows)} rows of {len(runs)} participants: {csv_path}, {html_path}")  # noqa: T201
        return 0
    except (ConfigError, StudyError) as exc:
        print(f"xr-relay study: {exc}", file=sys.stderr)  # noqa: T201
        return 2
