"""Benchmark 6: a peer for pose fan-out. The Foxglove SDK's WebSocket server (PyPI ``foxglove-sdk``, a Rust
server behind a Python API) fanning out the same poses to the same clients as benchmark 1.

Same producer (bench/relay_proc.py ``--server foxglove``: the synthetic robots' thread logs each pose,
encoded by relay.session.protocol exactly as xr-relay encodes it, on one JSON channel per robot), same client code
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
#: The second cell the peer is compared at: 300 robots to 5 clients.
PEER_CELL = (300, 5)
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
    # Quick: the target cell and a larger fleet to fewer clients (issue #15: 100x20 and 300x5).
    grid = [TARGET_CELL, PEER_CELL] if settings.quick else sorted({*fanout_cells(settings), PEER_CELL})
    results: list[JsonDict] = []
    for robots, clients in grid:
        # Alternate which server goes first: the machine's load drifts over a run.
        order = ("foxglove", "xr") if (robots + clients) % 2 else ("xr", "foxglove")
        for server in order:
            results.append(await fanout_cell(server, robots, clients, window=window, warmup=warmup, report=report))
    targets = []
    for cell in (TARGET_CELL, PEER_CELL):
        xr = find(results, "xr", *cell)
        fox = find(results, "foxglove", *cell)
        if not (xr and fox):
            continue
        p99, fox_p99 = xr["latency_ms"]["p99"], fox["latency_ms"]["p99"]
        cpu, fox_cpu = xr["cpu"]["server"], fox["cpu"]["server"]
        ahead = p99 is not None and fox_p99 is not None and p99 < fox_p99 and cpu < fox_cpu
        targets.append(
            target(
                f"xr-relay ahead of Foxglove, {cell[0]} robots x {cell[1]} clients",
                "p99 and CPU both below the peer's",
                f"p99 {fmt(p99, 2)} ms vs {fmt(fox_p99, 2)} ms ({fox_p99 / p99:.1f}x), CPU {100 * cpu:.0f} % vs "
                f"{100 * fox_cpu:.0f} % ({fox_cpu / cpu:.1f}x)"
                if p99 and cpu
                else "n/a",
                ahead,
                "" if ahead else "see the cells: the relay's p99 or CPU is not below the peer's in this run",
                baseline="Foxglove SDK server, same producer and clients, same run",
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
