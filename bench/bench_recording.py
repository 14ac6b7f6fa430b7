"""Benchmark: what recording a session costs (issue #34). The pose fan-out's target cell, 100 robots at 30 Hz to
20 clients (bench/bench_pose_fanout.py), with and without ``--record-session``, in the same run, taken in turns
(off, on, off, on) so that a machine that grows busier during the run weighs on both alike. Target: the relay's CPU
with recording at most 5 % above without; the poses' p99 latency beside it, and what the file grows by.
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

from .bench_pose_fanout import RATE, TARGET_CELL, fanout_cell
from .common import JsonDict, Report, Settings, fmt, target

NAME = "recording"
TITLE = "Session recording"
TARGET_RATIO = 1.05


async def run(settings: Settings, report: Report) -> JsonDict:
    robots, clients = TARGET_CELL
    window, warmup = settings.pick(10.0, 4.0), settings.pick(3.0, 1.5)
    rounds = int(settings.pick(3, 1))
    cells: list[JsonDict] = []
    with tempfile.TemporaryDirectory(prefix="xr-bench-recording-") as folder:
        for k in range(rounds):
            for recording in (False, True):
                path = Path(folder) / f"session-{k}.mcap"
                extra = ("--record-session", str(path)) if recording else ()
                cell = await fanout_cell(
                    "xr", robots, clients, window=window, warmup=warmup, report=report, extra=extra
                )
                cell["recording"] = recording
                if recording and path.exists():
                    cell["file_bytes"] = path.stat().st_size
                cells.append(cell)
    ok_cells = [c for c in cells if "error" not in c]
    off = [float(c["cpu"]["server"]) for c in ok_cells if not c["recording"]]
    on = [float(c["cpu"]["server"]) for c in ok_cells if c["recording"]]
    if not off or not on:
        return {
            "cells": cells,
            "targets": [target("relay CPU with recording", "<= 1.05x", "n/a", None, "cells failed")],
        }
    ratio = statistics.fmean(on) / statistics.fmean(off)
    p99_on = [c["latency_ms"]["p99"] for c in ok_cells if c["recording"] and c["latency_ms"]["p99"] is not None]
    p99_off = [c["latency_ms"]["p99"] for c in ok_cells if not c["recording"] and c["latency_ms"]["p99"] is not None]
    per_s = [c["file_bytes"] / (c["window_s"] + warmup) for c in ok_cells if "file_bytes" in c]
    cpu_on, cpu_off = 100 * statistics.fmean(on), 100 * statistics.fmean(off)
    report.line(f"relay CPU {cpu_off:.1f} % without, {cpu_on:.1f} % with")
    return {
        "cells": cells,
        "targets": [
            target(
                f"relay CPU with --record-session, {robots} robots x {clients} clients at 30 Hz",
                f"<= {TARGET_RATIO:.2f}x without",
                f"{ratio:.3f}x ({cpu_on:.1f} % of a core, without {cpu_off:.1f} %)",
                ratio <= TARGET_RATIO,
                ""
                if ratio <= TARGET_RATIO
                else f"{(cpu_on - cpu_off) * 1e4 / (robots * RATE):.0f} us of a core per pose recorded: the recorder's "
                "thread (mcap's framing of each message in Python, zstd per chunk) runs in the relay's process; it "
                "writes what gathered every 0.1 s (woken per message it cost 1.35x), and a process of its own is next",
                baseline=(
                    f"pose p99 {fmt(max(p99_on), 2) if p99_on else 'n/a'} ms with, "
                    f"{fmt(max(p99_off), 2) if p99_off else 'n/a'} ms without; "
                    f"the file grows by about {statistics.fmean(per_s) / 1e6:.2f} MB/s"
                    if per_s
                    else ""
                ),
            )
        ],
    }
