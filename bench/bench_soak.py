"""Soak: the relay with the simulated fleet under clients that come and go, for a long time.

    python bench/bench_soak.py --minutes 30          # the issue's run (not part of CI)
    python bench/bench_soak.py --minutes 3           # a short check

Five clients connect, stream a robot's camera at 5 fps and ping, disconnect after 5 to 20 s, and connect
again, at random (seeded), until the time is up. Counted: every `error` reply, every connection that closed
other than by the client, every hello missing. Sampled every 5 s: the relay process's resident memory
(/proc/PID/status). Verdict: zero errors, and the median memory of the last fifth of the run within 10 % of
the median of the second fifth (the first fifth is warm-up). Writes bench/results/soak.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import platform
import random
import re
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import orjson
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
TOKEN = "soak-token"
logger = logging.getLogger("soak")


def rss_kib(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    match = re.search(r"VmRSS:\s+(\d+) kB", status)
    return int(match.group(1)) if match else 0


class Tally:
    def __init__(self) -> None:
        self.sessions = 0
        self.messages = 0
        self.frames = 0
        self.errors: list[str] = []


async def client_loop(index: int, url: str, deadline: float, rng: random.Random, tally: Tally) -> None:
    robot = f"robot{index % 3 + 1}"
    while time.monotonic() < deadline:
        stay = min(rng.uniform(5.0, 20.0), max(0.0, deadline - time.monotonic()))
        try:
            async with connect(url, max_size=8 * 1024 * 1024) as ws:
                hello = orjson.loads(await asyncio.wait_for(ws.recv(), 10))
                if hello.get("identifier") != "hello":
                    tally.errors.append(f"client {index}: first message {hello.get('identifier')!r}")
                tally.sessions += 1
                await ws.send(
                    orjson.dumps({"identifier": f"{robot}/stream", "id": "s", "camera": "front", "fps": 5}).decode()
                )
                end = time.monotonic() + stay
                next_ping = time.monotonic()
                while time.monotonic() < end:
                    if time.monotonic() >= next_ping:
                        await ws.send(orjson.dumps({"identifier": "ping", "t": time.time()}).decode())
                        next_ping += 1.0
                    try:
                        data = await asyncio.wait_for(ws.recv(), timeout=max(0.05, end - time.monotonic()))
                    except TimeoutError:
                        continue
                    if isinstance(data, bytes):
                        tally.frames += 1
                        continue
                    tally.messages += 1
                    message = orjson.loads(data)
                    if message["identifier"] == "error":
                        tally.errors.append(f"client {index}: error {message['code']}: {message['message']}")
        except ConnectionClosed as exc:
            tally.errors.append(f"client {index}: connection closed by the relay: {exc}")
        except (OSError, TimeoutError) as exc:
            tally.errors.append(f"client {index}: {type(exc).__name__}: {exc}")
        await asyncio.sleep(rng.uniform(0.1, 2.0))


async def soak(minutes: float, seed: int) -> dict[str, Any]:
    relay = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", "--port", "0", "--token", TOKEN, "--allow-weak-token", "--audit-log", "",
        "--no-accounts", "--log-level", "warning",
        cwd=ROOT, stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    assert relay.stdout is not None
    line = (await asyncio.wait_for(relay.stdout.readline(), 60)).decode()
    base = line.split("open ")[1].split("/#")[0]
    url = base.replace("http", "ws") + f"/ws?token={TOKEN}"
    tally = Tally()
    rng = random.Random(seed)
    started = time.monotonic()
    deadline = started + minutes * 60
    samples: list[tuple[float, int]] = []

    async def sample() -> None:
        while time.monotonic() < deadline:
            samples.append((round(time.monotonic() - started, 1), rss_kib(relay.pid)))
            await asyncio.sleep(5.0)

    try:
        await asyncio.gather(
            sample(), *(client_loop(i, url, deadline, random.Random(rng.random()), tally) for i in range(5))
        )
    finally:
        relay.terminate()
        await relay.wait()
    fifth = max(1, len(samples) // 5)
    early = statistics.median(kib for _, kib in samples[fifth : 2 * fifth])
    late = statistics.median(kib for _, kib in samples[-fifth:])
    drift = (late - early) / early
    return {
        "benchmark": "soak",
        "machine": {"python": platform.python_version(), "platform": platform.platform()},
        "parameters": {"minutes": minutes, "clients": 5, "robots": 3, "stream_fps": 5, "seed": seed},
        "figures": {
            "sessions": tally.sessions,
            "messages": tally.messages,
            "frames": tally.frames,
            "errors": len(tally.errors),
            "rss_kib_early_median": early,
            "rss_kib_late_median": late,
            "rss_drift": round(drift, 4),
        },
        "errors": tally.errors[:20],
        "rss_samples": samples,
        "verdict": "pass" if not tally.errors and abs(drift) <= 0.10 else "fail",
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=20261121)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    result = asyncio.run(soak(args.minutes, args.seed))
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "soak.json").write_text(json.dumps(result, indent=2) + "\n")
    figures = result["figures"]
    logger.info(
        "soak %.0f min: %d sessions, %d messages, %d frames, %d errors; RSS %.1f -> %.1f MiB (%+.1f %%): %s",
        args.minutes, figures["sessions"], figures["messages"], figures["frames"], figures["errors"],
        figures["rss_kib_early_median"] / 1024, figures["rss_kib_late_median"] / 1024, 100 * figures["rss_drift"],
        result["verdict"],
    )  # fmt: skip
    return 0 if result["verdict"] == "pass" else 1


if __name__ == "__main__":
    sys.exit(main())
