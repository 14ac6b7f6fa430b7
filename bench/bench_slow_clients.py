"""Benchmark 4: slow and many clients.

1. One stalled client among five: three synthetic robots at 30 Hz plus a live 480x480 JPEG stream at
   30 fps (the fisheye photo), received by four clients; the fifth completes the WebSocket handshake, asks
   for the same stream, and never reads again (a raw socket with a small receive buffer). Figures: the four
   others' pose and frame latency p99 against a run without the stalled client (same relay code, fresh
   process), and the relay's resident memory every half second (target: growth < 20 MB).
2. 50 clients connecting within one second (one every 20 ms) to a relay under the same load: time from
   the TCP connect to the ``hello`` frame, p50/p99.

The relay (bench/relay_proc.py, synthetic backend) runs in its own process; the clients here.
"""

from __future__ import annotations

import asyncio
import time

import orjson

from .common import FISHEYE, TOKEN, Child, CpuWindow, JsonDict, ProcStat, Report, Settings, fmt, summary, target
from .wsload import Recorder, StalledClient, WsClient, close_all, connect, connect_many

NAME = "slow_clients"
TITLE = "Slow and many clients"
ROBOTS = 3
RECEIVERS = 4
CAMERA_FPS = 30.0
SIZE = 480
TARGET_GROWTH_MB = 20.0
BURST = 50
BURST_SPAN = 1.0
STREAM = orjson.dumps({"identifier": "r001/stream", "id": "live", "camera": "front", "fps": CAMERA_FPS})


async def start_relay(name: str) -> tuple[Child, int]:
    child = await Child.start(
        name,
        [
            "-m",
            "bench.relay_proc",
            "--server",
            "xr",
            "--robots",
            str(ROBOTS),
            "--camera-jpeg",
            str(FISHEYE / "front.jpg"),
            "--camera-size",
            str(SIZE),
            str(SIZE),
            "--camera-rate",
            str(CAMERA_FPS),
            "--token",
            TOKEN,
        ],
    )
    ready = await child.wait_for(lambda line: "port" in line, 60)
    await child.request("start")
    return child, int(ready["port"])


async def stream_run(*, stalled: bool, duration: float, report: Report) -> tuple[JsonDict, JsonDict | None]:
    """One run; the run without the stalled client also hosts the connection burst afterwards (its four
    clients still streaming: the relay under its usual load)."""
    child, port = await start_relay(f"slow-{'stalled' if stalled else 'alone'}")
    recorder = Recorder()
    clients: list[WsClient] = []
    stall: StalledClient | None = None
    try:
        clients = await connect_many(recorder, port, RECEIVERS, path=f"/ws?token={TOKEN}")
        for client in clients:
            client.send(STREAM)
        if stalled:
            stall = await asyncio.to_thread(StalledClient, port, f"/ws?token={TOKEN}", [STREAM])
        await asyncio.sleep(1.0)  # streams running, the stalled client's buffers filling
        stat = ProcStat(child.pid)
        cpu = CpuWindow({"relay": child.pid})
        for client in clients:
            client.reset_counts()
        recorder.reset()
        recorder.active = True
        cpu.start()
        t0 = time.monotonic()
        rss: list[tuple[float, float]] = []
        while (now := time.monotonic()) - t0 < duration:
            rss.append((round(now - t0, 2), round(stat.rss() / 2**20, 2)))
            await asyncio.sleep(0.5)
        recorder.active = False
        use = cpu.stop()
        rss.append((round(time.monotonic() - t0, 2), round(stat.rss() / 2**20, 2)))
        elapsed = use["wall"]
        mib = [m for _, m in rss]
        result: JsonDict = {
            "stalled": stalled,
            "duration_s": round(elapsed, 1),
            "pose_latency_ms": summary(recorder.pose_latency),
            "frame_latency_ms": summary(recorder.frame_latency),
            "poses_per_client_per_s": round(sum(c.poses for c in clients) / len(clients) / elapsed, 1),
            "fps_per_client": round(sum(c.frames for c in clients) / len(clients) / elapsed, 1),
            "cpu": use,
            "rss_mib": rss,
            "rss_growth_mib": round(max(mib) - mib[0], 2),
        }
        report.line(
            f"{'with' if stalled else 'without'} the stalled client, {elapsed:.0f} s: pose p99 "
            f"{fmt(result['pose_latency_ms']['p99'], 2)} ms, frame p99 {fmt(result['frame_latency_ms']['p99'], 2)} ms, "
            f"{result['fps_per_client']} fps per client, RSS {mib[0]:.1f} -> {mib[-1]:.1f} MiB "
            f"(max {max(mib):.1f}), relay CPU {100 * use['relay']:.0f} %"
        )
        return result, None if stalled else await burst(port, report)
    finally:
        close_all(clients)
        if stall is not None:
            stall.close()
        await child.stop()


async def burst(port: int, report: Report) -> JsonDict:
    """50 clients within one second; each one's time from connect to hello."""
    recorder = Recorder()
    opened: list[WsClient] = []

    async def one(delay: float) -> float | str:
        await asyncio.sleep(delay)
        t0 = time.monotonic()
        try:
            client = await connect(recorder, port, path=f"/ws?token={TOKEN}", within=10.0)
        except (TimeoutError, ConnectionError, OSError) as exc:
            return f"{type(exc).__name__}: {exc}"
        opened.append(client)
        return await client.hello - t0

    try:
        outcomes = await asyncio.gather(*(one(i * BURST_SPAN / BURST) for i in range(BURST)))
    finally:
        close_all(opened)
    times = [o for o in outcomes if isinstance(o, float)]
    failures = [o for o in outcomes if isinstance(o, str)]
    result: JsonDict = {"clients": BURST, "span_s": BURST_SPAN, "hello_ms": summary(times), "failures": failures}
    report.line(
        f"{BURST} clients in {BURST_SPAN:g} s: hello p50 {fmt(result['hello_ms']['p50'], 2)} ms, "
        f"p99 {fmt(result['hello_ms']['p99'], 2)} ms, {len(failures)} failed"
    )
    return result


async def run(settings: Settings, report: Report) -> JsonDict:
    alone_s = settings.pick(20.0, 4.0)
    stalled_s = settings.pick(60.0, 15.0)
    alone, connecting = await stream_run(stalled=False, duration=alone_s, report=report)
    stalled, _ = await stream_run(stalled=True, duration=stalled_s, report=report)
    assert connecting is not None
    targets = []
    a, b = alone["pose_latency_ms"]["p99"], stalled["pose_latency_ms"]["p99"]
    if a and b:
        targets.append(
            target(
                "others' pose p99 with a stalled client",
                "reported as a ratio to the run without it (no target given)",
                f"{b:.2f} ms = {b / a:.2f}x",
                None,
                "",
                baseline=f"without it: {a:.2f} ms",
            )
        )
    growth = stalled["rss_growth_mib"] * 2**20 / 1e6
    targets.append(
        target(
            f"relay memory growth over {stalled['duration_s']:.0f} s with a stalled client",
            f"< {TARGET_GROWTH_MB:g} MB",
            f"{growth:.1f} MB",
            growth < TARGET_GROWTH_MB,
            "" if growth < TARGET_GROWTH_MB else "see the RSS curve",
            baseline=f"without it: {alone['rss_growth_mib'] * 2**20 / 1e6:.1f} MB over {alone['duration_s']:.0f} s",
        )
    )
    hello = connecting["hello_ms"]
    targets.append(
        target(
            f"{BURST} clients connecting within {BURST_SPAN:g} s: time to hello",
            "reported (no target given)",
            f"p50 {fmt(hello['p50'], 1)} ms, p99 {fmt(hello['p99'], 1)} ms, {len(connecting['failures'])} failed",
            None,
        )
    )
    return {
        "parameters": {
            "robots": ROBOTS,
            "pose_rate_hz": 30.0,
            "camera": f"{SIZE}x{SIZE} JPEG at {CAMERA_FPS:g} fps",
            "receivers": RECEIVERS,
            "alone_s": alone_s,
            "stalled_s": stalled_s,
            "stalled_client": "raw socket, SO_RCVBUF 16 KiB, handshake + stream request, never reads",
        },
        "alone": alone,
        "stalled": stalled,
        "burst": connecting,
        "targets": targets,
    }
