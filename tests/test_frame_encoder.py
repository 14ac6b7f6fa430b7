"""One camera's frames: one encode in flight, the newest image wins, the stream rate is kept, snapshots wait.

The encoder runs its conversions in a real thread pool and hands results back through the loop, as both
backends do; the clock that decides whether a stream is due a frame is a number the test moves.
"""

from __future__ import annotations

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import pytest

from relay.events import FrameEvent
from relay.frame_encoder import LatestFrameEncoder
from relay.imaging import ImageError


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Images:
    """A converter that blocks on a gate, so a test decides when an encode finishes."""

    def __init__(self) -> None:
        self.gate = threading.Event()
        self.gate.set()
        self.converted: list[int] = []

    def convert(self, image: int) -> FrameEvent:
        self.gate.wait(5.0)
        if image < 0:
            raise ImageError(f"image {image} is not an image")
        self.converted.append(image)
        return FrameEvent("robot1", "front", float(image), 4, 3, b"jpeg%d" % image)


@pytest.fixture
async def setup() -> Any:
    loop = asyncio.get_running_loop()
    pool = ThreadPoolExecutor(max_workers=2)
    images, clock = Images(), Clock()
    delivered: list[FrameEvent] = []
    encoder: LatestFrameEncoder[int] = LatestFrameEncoder(
        "robot1 camera front", images.convert, pool, loop.call_soon_threadsafe, delivered.append, clock
    )
    yield encoder, images, clock, delivered
    images.gate.set()
    pool.shutdown(wait=True)


async def settle(encoder: LatestFrameEncoder[int]) -> None:
    """Until no encode is in flight and its frame reached the loop (the pool is real: wait, bounded)."""
    for _ in range(2000):
        if not encoder.encoding:
            return
        await asyncio.sleep(0.001)
    raise AssertionError("the encoder did not finish in 2 s")


async def test_nobody_watching_costs_no_encode(setup: Any) -> None:
    encoder, images, clock, delivered = setup
    for i in range(10):
        encoder.offer(i)
        clock.now += 0.1
    await asyncio.sleep(0.05)
    assert images.converted == [] and delivered == []


async def test_a_stream_gets_frames_at_its_rate_not_the_cameras(setup: Any) -> None:
    encoder, images, clock, delivered = setup
    encoder.fps = 10.0  # one frame per 0.1 s (0.09 s with the slack)
    for i in range(30):  # a 100 fps camera for 0.3 s
        encoder.offer(i)
        await settle(encoder)
        clock.now += 0.01
    assert images.converted == [0, 9, 18, 27]
    assert [f.stamp for f in delivered] == [0.0, 9.0, 18.0, 27.0]


async def test_the_newest_image_wins_while_an_encode_is_in_flight(setup: Any) -> None:
    encoder, images, clock, delivered = setup
    encoder.fps = 1000.0
    images.gate.clear()  # the first encode takes "long"
    encoder.offer(1)
    for i in range(2, 8):
        clock.now += 0.01
        encoder.offer(i)
    images.gate.set()
    await settle(encoder)
    assert images.converted == [1, 7], "the images that arrived during the encode were dropped but the newest"
    assert [f.stamp for f in delivered] == [1.0, 7.0]


async def test_a_snapshot_takes_a_fresh_frame_or_waits_for_the_next(setup: Any) -> None:
    encoder, _, clock, _ = setup
    snapshot = asyncio.ensure_future(encoder.snapshot(2.0, max_age=1.0))
    await asyncio.sleep(0)
    assert encoder.waiting
    encoder.offer(5)  # not streaming, but a snapshot waits: encoded
    frame = await snapshot
    assert frame is not None and frame.stamp == 5.0 and not encoder.waiting
    clock.now += 0.5
    assert await encoder.snapshot(2.0, max_age=1.0) is frame, "half a second old: fresh enough"
    clock.now += 1.0
    assert await encoder.snapshot(0.05, max_age=1.0) is None, "stale, and no image comes"


async def test_a_recordings_snapshot_encodes_its_newest_image_and_an_unreadable_one_answers_none(setup: Any) -> None:
    _, images, clock, _ = setup
    loop = asyncio.get_running_loop()
    pool = ThreadPoolExecutor(max_workers=1)
    delivered: list[FrameEvent] = []
    encoder: LatestFrameEncoder[int] = LatestFrameEncoder(
        "bag camera", images.convert, pool, loop.call_soon_threadsafe, delivered.append, clock, keep_latest=True
    )
    encoder.offer(3)  # a paused replay's image: nobody streams it
    frame = await encoder.snapshot(2.0, max_age=None, on_wait=encoder.encode_latest)
    assert frame is not None and frame.stamp == 3.0
    clock.now += 60.0
    assert await encoder.snapshot(2.0, max_age=None, on_wait=encoder.encode_latest) is frame, "still the newest"
    encoder.offer(-1)
    assert await encoder.snapshot(2.0, max_age=None, on_wait=encoder.encode_latest) is None
    encoder.forget_latest()
    assert encoder.latest is None
    pool.shutdown(wait=True)
