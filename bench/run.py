"""Run the benchmarks and regenerate the report: ``make bench`` (``QUICK=1`` for the development subset).

    python -m bench.run [--quick] [--only NAME ...] [--report-only]

Full runs write bench/results/<name>.json, docs/benchmarks.md and docs/img/bench_*.png (committed). Quick
runs write the same under bench/results/scratch/quick/ (ignored by git), so a development run never changes the
committed figures. ``--only`` reruns some benchmarks and regenerates the page from every stored result.
"""

from __future__ import annotations

import argparse
import asyncio
import datetime
import logging
import sys
import time
import traceback
from collections.abc import Awaitable, Callable
from types import ModuleType

from . import (
    bench_arm,
    bench_camera,
    bench_client_frame,
    bench_cloud,
    bench_estop,
    bench_foxglove_peer,
    bench_map_beside,
    bench_map_frame,
    bench_pose_fanout,
    bench_recording,
    bench_ros_ingest,
    bench_slow_clients,
    bench_video,
    report,
)
from .common import JsonDict, Report, Settings, machine, versions, write_result

BENCHMARKS: tuple[ModuleType, ...] = (
    bench_pose_fanout,
    bench_ros_ingest,
    bench_camera,
    bench_slow_clients,
    bench_client_frame,
    bench_foxglove_peer,
    bench_video,
    bench_estop,
    bench_recording,
    bench_arm,
    bench_cloud,
    bench_map_frame,
    bench_map_beside,
)


async def run_one(module: ModuleType, settings: Settings, env: JsonDict) -> JsonDict:
    name: str = module.NAME
    out = Report(name)
    started = time.monotonic()
    stamp = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    load_before = machine()["load_average"]
    body: JsonDict
    try:
        runner: Callable[[Settings, Report], Awaitable[JsonDict]] = module.run
        body = await runner(settings, out)
    except Exception as exc:  # one broken benchmark must not hide the others' figures
        out.line(f"FAILED: {exc!r}")
        body = {"error": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc(), "targets": []}
    result: JsonDict = {
        "name": name,
        "title": module.TITLE,
        "quick": settings.quick,
        "started": stamp,
        "duration_s": round(time.monotonic() - started, 1),
        "machine": {
            **env["machine"],
            "load_average_before": load_before,
            "load_average_after": machine()["load_average"],
        },
        "versions": env["versions"],
        **body,
    }
    path = write_result(settings, name, result)
    out.line(f"done in {result['duration_s']} s -> {path}")
    return result


async def main_async(settings: Settings, report_only: bool) -> int:
    if not report_only:
        env = {"machine": machine(), "versions": await asyncio.to_thread(versions)}
        for module in BENCHMARKS:
            if settings.only and module.NAME not in settings.only:
                continue
            await run_one(module, settings, env)
    page = report.write(settings)
    Report("report").line(f"wrote {page}")
    return 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="the development subset (under 2 minutes)")
    parser.add_argument("--only", nargs="+", default=[], help="benchmark names to run (the page keeps the others)")
    parser.add_argument("--report-only", action="store_true", help="regenerate the page from stored results")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    names = {m.NAME for m in BENCHMARKS}
    unknown = set(args.only) - names
    if unknown:
        parser.error(f"unknown benchmark {', '.join(sorted(unknown))}; known: {', '.join(sorted(names))}")
    settings = Settings.create(args.quick, args.only)
    sys.exit(asyncio.run(main_async(settings, args.report_only)))


if __name__ == "__main__":
    main()
