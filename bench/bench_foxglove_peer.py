"""Benchmark 6: a peer for pose fan-out. The Foxglove SDK's WebSocket server (PyPI ``foxglove-sdk``, a Rust
server behind a Python API) fanning out the same poses to the same clients as benchmark 1.

Same producer (bench/relay_proc.py ``--server foxglove``: the synthetic robots' thread logs each pose,
encoded by relay.protocol exactly as xr-relay encodes it, on one JSON channel per robot), same client code
(bench/wsload.py: the Foxglove subprotocol, a subscription to every advertised channel, then the same
stamp reading from each message). xr-relay is measured again in the same run, cell by cell, for the ratio.
Foxglove keeps up to 1024 messages per client and drops the oldest; it does not coalesce.
"""

from __future__ import annotations

import importlib.util

from .bench_pose_fanout import TARGET_CELL, fanout_cell, find
from .bench_pose_fanout import cells as fanout_cells
from .common import JsonDict, Report, Settings, fmt, target

NAME = "foxglove_peer"
TITLE = "Peer: Foxglove SDK WebSocket server"


def unavailable() -> str | None:
    if importlib.util.find_spec("foxglove") is None:
        return "the foxglove-sdk package is not installed (pip install foxglove-sdk)"
    try:
        import foxglove

        foxglove.Context()
    except Exception as exc:  # a wheel for another platform, a missing shared library
        return f"foxglove-sdk does not load here: {exc!r}"
    return None


async def run(settings: Settings, report: Report) -> JsonDict:
    reason = unavailable()
    if reason is not None:
        report.line(f"skipped: {reason}")
        return {"skipped": reason, "targets": [target("Foxglove peer", "reference", "n/a", None, reason)]}
    window = settings.pick(4.0, 1.5)
    warmup = settings.pick(1.0, 0.4)
    # Quick: the target cell only (benchmark 1 covers a small one).
    grid = [TARGET_CELL] if settings.quick else fanout_cells(settings)
    results: list[JsonDict] = []
    for robots, clients in grid:
        # Alternate which server goes first: the machine's load drifts over a run.
        order = ("foxglove", "xr") if (robots + clients) % 2 else ("xr", "foxglove")
        for server in order:
            results.append(await fanout_cell(server, robots, clients, window=window, warmup=warmup, report=report))
    xr = find(results, "xr", *TARGET_CELL)
    fox = find(results, "foxglove", *TARGET_CELL)
    targets = []
    if xr and fox:
        targets.append(
            target(
                "p99 latency, 100 robots x 20 clients, xr-relay vs Foxglove",
                "reference (no target)",
                f"xr-relay {fmt(xr['latency_ms']['p99'], 2)} ms, Foxglove {fmt(fox['latency_ms']['p99'], 2)} ms",
                None,
                baseline=f"CPU xr-relay {100 * xr['cpu']['server']:.0f} %, Foxglove {100 * fox['cpu']['server']:.0f} %",
            )
        )
    return {
        "parameters": {
            "rate_hz": 30.0,
            "robots": sorted({r for r, _ in grid}),
            "clients": sorted({c for _, c in grid}),
            "window_s": window,
            "warmup_s": warmup,
            "servers": ["foxglove", "xr"],
        },
        "cells": results,
        "targets": targets,
    }
