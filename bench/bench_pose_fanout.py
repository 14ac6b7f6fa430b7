"""Benchmark 1: pose fan-out. R robots at 30 Hz to C WebSocket clients, no ROS.

The server runs in its own process (bench/relay_proc.py) with a synthetic backend whose producer thread
stamps each pose with ``time.monotonic()`` (CLOCK_MONOTONIC, shared by every process) just before it
crosses to the relay's loop; the clients run in this process (bench/wsload.py) and subtract that stamp
from their receive time. So the latency is what the relay adds: thread hop, encoding, queueing, sending,
loopback, and the client's own read. The relay's CPU is its process's CPU time over the wall time.

Baseline, same run, same producer, same clients: the naive relay (relay_proc ``--server naive``), the way
the thesis prototype worked, and xr-relay itself with one frame per message (``xr-single``: clients that do not
ask for batches, as protocol v1 clients). ``xr`` is xr-relay with batching (``/ws?batch=1``, relay.station.hub): what
the web client uses. Target (issue #15): 100 robots x 20 clients with p99 <= 5 ms and relay CPU <= 50 % of one core.
"""

from __future__ import annotations

import asyncio
import os
import time
from typing import Any

from .common import TOKEN, Child, CpuWindow, JsonDict, ProcStat, Report, Settings, fmt, summary, target
from .wsload import Recorder, close_all, connect_many

NAME = "pose_fanout"
TITLE = "Pose fan-out"
RATE = 30.0
ROBOTS = (1, 10, 100, 300)
CLIENTS = (1, 5, 20, 50)
QUICK_CELLS = ((10, 5), (100, 20))
TARGET_CELL = (100, 20)
TARGET_P99_MS = 5.0
TARGET_CPU = 0.50
#: A large fleet (issue #15): 1000 robots x 5 clients at 10 Hz, every client keeps up (>= 95 % of the poses)
#: with the relay under 80 % of a core.
BIG_CELL = (1000, 5)
BIG_RATE = 10.0
TARGET_BIG_DELIVERED = 0.95
TARGET_BIG_CPU = 0.80


async def fanout_cell(
    server: str,
    robots: int,
    clients: int,
    *,
    window: float,
    warmup: float,
    report: Report,
    rate: float = RATE,
    extra: tuple[str, ...] = (),
) -> JsonDict:
    """One (server, R, C) measurement, ``extra`` arguments to the server; never raises for a server that fails: the
    cell records why."""
    kind = "foxglove" if server == "foxglove" else "xr"
    path = "/" if kind == "foxglove" else f"/ws?batch=1&token={TOKEN}" if server == "xr" else f"/ws?token={TOKEN}"
    process = "xr" if server == "xr-single" else server
    child = await Child.start(
        f"fanout-{server}-{robots}x{clients}",
        [
            "-m",
            "bench.relay_proc",
            "--server",
            process,
            "--robots",
            str(robots),
            "--rate",
            str(rate),
            "--token",
            TOKEN,
            *extra,
        ],
    )
    recorder = Recorder()
    conns: list[Any] = []
    cell: JsonDict = {"server": server, "robots": robots, "clients": clients, "rate_hz": rate}
    try:
        ready = await child.wait_for(lambda line: "port" in line, 60)
        conns = await connect_many(recorder, ready["port"], clients, path=path, kind=kind)
        await child.request("start")
        await asyncio.sleep(warmup)
        for conn in conns:
            conn.reset_counts()
        recorder.reset()
        cpu = CpuWindow({"server": child.pid})
        before = await child.request("stats", 30)
        recorder.active = True
        cpu.start()
        t0 = time.monotonic()
        await asyncio.sleep(window)
        recorder.active = False
        elapsed = time.monotonic() - t0
        cpu_use = cpu.stop()
        after = await child.request("stats", 30)
        published = (after["events"] - before["events"]) / (after["t"] - before["t"])
        per_client = [c.poses / elapsed for c in conns]
        received = sum(c.poses for c in conns)
        wire = [c.bytes / elapsed for c in conns]
        cell.update(
            {
                "offered_per_s": robots * rate,
                "published_per_s": round(published, 1),
                "delivered_per_client_per_s": round(sum(per_client) / len(per_client), 1),
                "delivered_fraction": round(sum(per_client) / len(per_client) / published, 4) if published else None,
                "delivered_min_fraction": round(min(per_client) / published, 4) if published else None,
                "latency_ms": summary(recorder.pose_latency),
                "bytes_per_client_per_s": round(sum(wire) / len(wire)),
                "bytes_per_message": round(sum(c.bytes for c in conns) / received, 1) if received else None,
                "cpu": cpu_use,
                "server_rss_mib": round(ProcStat(child.pid).rss() / 2**20, 1),
                # Other work on the machine shows here: a starved server is not a slow one.
                "load_average_1m": round(os.getloadavg()[0], 2),
                "window_s": round(elapsed, 2),
            }
        )
        lat = cell["latency_ms"]
        report.line(
            f"{server:8s} R={robots:3d} C={clients:2d}: p50 {fmt(lat['p50'], 2)} ms p99 {fmt(lat['p99'], 2)} ms, "
            f"server CPU {100 * cpu_use['server']:.0f} %, clients CPU {100 * cpu_use['load_generator']:.0f} %, "
            f"delivered {100 * (cell['delivered_fraction'] or 0):.0f} % of {published:.0f}/s, "
            f"{cell['bytes_per_client_per_s'] / 1000:.1f} kB/s per client"
        )
    except (TimeoutError, ConnectionError, OSError) as exc:
        cell["error"] = f"{type(exc).__name__}: {exc}"
        report.line(f"{server} R={robots} C={clients}: FAILED {cell['error']}")
    finally:
        close_all(conns)
        await child.stop()
    return cell


def cells(settings: Settings) -> list[tuple[int, int]]:
    if settings.quick:
        return list(QUICK_CELLS)
    return [(r, c) for r in ROBOTS for c in CLIENTS]


def find(cells_: list[JsonDict], server: str, robots: int, clients: int, rate: float = RATE) -> JsonDict | None:
    return next(
        (
            c
            for c in cells_
            if (c["server"], c["robots"], c["clients"], c.get("rate_hz", RATE)) == (server, robots, clients, rate)
            and "error" not in c
        ),
        None,
    )


def sent_per_s(cell: JsonDict) -> float:
    return float(cell.get("delivered_per_client_per_s") or 0.0) * int(cell["clients"])


def cost_per_message(cell: JsonDict) -> float | None:
    """Server CPU seconds per WebSocket message sent (all clients), in microseconds."""
    sent = sent_per_s(cell)
    return 1e6 * float(cell["cpu"]["server"]) / sent if sent else None


def targets(results: list[JsonDict]) -> list[JsonDict]:
    out = []
    xr = find(results, "xr", *TARGET_CELL)
    naive = find(results, "naive", *TARGET_CELL)
    single = find(results, "xr-single", *TARGET_CELL)
    unbatched = (
        f"; one frame per message: {fmt(single['latency_ms']['p99'], 2)} ms, {100 * single['cpu']['server']:.0f} %"
        if single
        else ""
    )
    if xr is None:
        return [target("p99 latency, 100 robots x 20 clients", "<= 5 ms", "n/a", None, "the cell failed")]
    p99, p50 = xr["latency_ms"]["p99"], xr["latency_ms"]["p50"]
    cpu = xr["cpu"]["server"]
    base = naive["latency_ms"]["p99"] if naive else None
    ok = p99 is not None and p99 <= TARGET_P99_MS
    out.append(
        target(
            "p99 relay-added latency, 100 robots x 20 clients",
            f"<= {TARGET_P99_MS:g} ms",
            f"{fmt(p99, 2)} ms (p50 {fmt(p50, 2)} ms)",
            ok,
            "" if ok else why(xr),
            baseline=f"naive relay {fmt(base, 1)} ms"
            + (f" ({base / p99:.1f}x xr-relay)" if base and p99 else "")
            + unbatched,
        )
    )
    naive_cpu = naive["cpu"]["server"] if naive else None
    per = cost_per_message(xr)
    naive_per = cost_per_message(naive) if naive else None
    ok = cpu <= TARGET_CPU
    out.append(
        target(
            "relay CPU, 100 robots x 20 clients",
            f"<= {100 * TARGET_CPU:.0f} % of one core",
            f"{100 * cpu:.0f} %",
            ok,
            "" if ok else f"{fmt(per, 1)} µs of relay CPU per message sent, {sent_per_s(xr):.0f} messages a second",
            baseline=(
                f"naive relay {100 * naive_cpu:.0f} %, {fmt(naive_per, 1)} µs per message sent" if naive_cpu else ""
            )
            + unbatched,
        )
    )
    big = find(results, "xr", *BIG_CELL, BIG_RATE)
    if big is None:
        out.append(target("1000 robots x 5 clients at 10 Hz", "every client keeps up", "n/a", None, "the cell failed"))
    else:
        kept, big_cpu = big.get("delivered_min_fraction") or 0.0, big["cpu"]["server"]
        ok = kept >= TARGET_BIG_DELIVERED and big_cpu <= TARGET_BIG_CPU
        big_naive = find(results, "naive", *BIG_CELL, BIG_RATE)
        out.append(
            target(
                "1000 robots x 5 clients at 10 Hz",
                f">= {100 * TARGET_BIG_DELIVERED:.0f} % of poses to every client, "
                f"relay CPU <= {100 * TARGET_BIG_CPU:.0f} %",
                f"{100 * kept:.1f} % to the slowest client (p99 {fmt(big['latency_ms']['p99'], 1)} ms), "
                f"{100 * big_cpu:.0f} % CPU",
                ok,
                "" if ok else why(big),
                baseline=(
                    f"naive relay {100 * (big_naive['delivered_fraction'] or 0):.1f} % delivered, "
                    f"p99 {fmt(big_naive['latency_ms']['p99'], 1)} ms, {100 * big_naive['cpu']['server']:.0f} % CPU"
                    if big_naive
                    else ""
                ),
            )
        )
    return out


def why(cell: JsonDict) -> str:
    """The measured reason a cell is slow, from its own figures."""
    reasons = []
    cpu = cell["cpu"]
    load = cell.get("load_average_1m", 0.0)
    cores = os.cpu_count() or 1
    if cpu["server"] >= 0.9:
        reasons.append(f"the server process was CPU-bound ({100 * cpu['server']:.0f} % of a core)")
    elif load > cores:
        reasons.append(
            f"the machine was oversubscribed (load average {load:.1f} on {cores} cores) while the server used "
            f"{100 * cpu['server']:.0f} % of a core: the tail is waiting for the CPU"
        )
    if cpu["load_generator"] >= 0.85:
        reasons.append(f"the clients' process was saturated ({100 * cpu['load_generator']:.0f} % of a core)")
    if cell.get("delivered_fraction") is not None and cell["delivered_fraction"] < 0.95:
        reasons.append(f"each client got {100 * cell['delivered_fraction']:.0f} % of the poses (coalesced or lost)")
    return "; ".join(reasons)


async def run(settings: Settings, report: Report) -> JsonDict:
    window = settings.pick(4.0, 1.5)
    warmup = settings.pick(1.0, 0.4)
    results: list[JsonDict] = []
    for robots, clients in cells(settings):
        for server in ("xr", "xr-single", "naive"):
            results.append(await fanout_cell(server, robots, clients, window=window, warmup=warmup, report=report))
    for server in ("xr", "naive"):
        results.append(await fanout_cell(server, *BIG_CELL, window=window, warmup=warmup, report=report, rate=BIG_RATE))
    return {
        "parameters": {
            "rate_hz": RATE,
            "robots": sorted({r for r, _ in cells(settings)}),
            "clients": sorted({c for _, c in cells(settings)}),
            "window_s": window,
            "warmup_s": warmup,
            "servers": ["xr", "xr-single", "naive"],
        },
        "cells": results,
        "targets": targets(results),
    }
