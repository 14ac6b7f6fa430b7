"""The /ws fuzz with its memory traced, in a process of its own: ``python -m tests.helpers.ws_fuzz_memory SEED COUNT``
starts a relay (the simulated fleet, port 0), sends COUNT generated bad frames (tests/helpers/bad_frames.py's
mutated_frames), traces what the relay's code and its server library hold after the first 100 and prints one JSON
line of what it saw. The process exits without stopping the tracer: in CPython 3.11, tracemalloc.stop() while the
relay's threads allocate crashed a pytest worker (seen once in a fresh clone's run), and tracing left on would have
slowed the worker's next tests."""

from __future__ import annotations

import asyncio
import json
import os
import random
import sys
import tracemalloc

from relay.config import load_config
from tests.conftest import ROOT, start_relay
from tests.helpers.bad_frames import mutated_frames
from tests.helpers.spy import CommandSpy
from tests.wsclient import TestClient

#: Frames sent before tracing starts: they fill the relay's caches (tracing all of them slowed the fleet too).
WARM_UP = 100


def relay_memory() -> tracemalloc.Snapshot:
    """Memory held by the relay's own code and its server library (the test client keeps every message). Not the
    simulator's: its laser's per-tick arrays (889 KiB twice, seen in CI as "1.85 MB grown") are alive or not
    depending on when the snapshot falls, whatever the frames."""
    return tracemalloc.take_snapshot().filter_traces(
        [
            tracemalloc.Filter(True, "*/relay/*"),
            tracemalloc.Filter(True, "*/aiohttp/*"),
            tracemalloc.Filter(False, "*/relay/sim/*"),
        ]
    )


async def fuzz(seed: int, count: int) -> dict[str, object]:
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config)
    try:
        spy = CommandSpy(running.relay.backend)  # type: ignore[arg-type]
        client = await TestClient.open(running.ws_url)
        await client.hello()
        replies: list[str] = []
        baseline: tracemalloc.Snapshot | None = None
        for index, frame in enumerate(mutated_frames(random.Random(seed), count)):
            if index == WARM_UP:
                tracemalloc.start()
                baseline = relay_memory()
            start = len(client.messages)
            await client.send_raw(frame)
            reply = await client.wait_for(lambda m: m["identifier"] in ("error", "ack"), start=start, timeout=10)
            replies.append(reply["identifier"] if reply["identifier"] == "error" else f"{reply} to {frame!r:.200}")
            # Rate limit (60/s) is not what is under test here: pace the stream under it.
            await asyncio.sleep(0.012)
        assert baseline is not None, f"{count} frames: fewer than the {WARM_UP} of the warm-up"
        diff = relay_memory().compare_to(baseline, "lineno")
        after = await client.request({"identifier": "robot1/cancel"})
        await client.close()
        return {
            "frames": count,
            "not_errors": [r for r in replies if r != "error"],
            "grown": sum(stat.size_diff for stat in diff),
            "biggest": [str(stat) for stat in sorted(diff, key=lambda s: -s.size_diff)[:5]],
            "moving": [repr(c) for c in spy.moving_commands()],
            "after": after["identifier"],
        }
    finally:
        await running.runner.cleanup()


def main() -> None:
    seed, count = int(sys.argv[1]), int(sys.argv[2])
    result = asyncio.run(fuzz(seed, count))
    print(json.dumps(result), flush=True)  # noqa: T201 (the test reads it)
    os._exit(0)  # the tracer is still on: never stopped (see the module's docstring)


if __name__ == "__main__":
    main()
