"""One camera's frames: two encodes in flight, the newest image wins, in order, the stream rate is kept even with
jitter, snapshots wait.

The encoder runs its conversions in a real thread pool and hands results back through the loop, as both
backends do; the clock that decides whether a stream is due a frame is a number the test moves.
"""

from __future__ import annotations

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import pytest

from relay.fleet.events import FrameEvent
from relay.media.frame_encoder import LatestFrameEncoder
from relay.media.imaging import ImageError


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


class Images:
    """A converter that blocks on a gate, so a test decides when an encode finishes (``gates``: per image)."""

    def __init__(self) -> None:
        self.gate = threading.Event()
        self.gate.set()
        self.gates: dict[int, threading.Event] = {}
        self.converted: list[int] = []

    def convert(self, image: int) -> FrameEvent:
        self.gate.wait(5.0)
        if image in self.gates:
            self.gates[image].wait(5.0)
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
    encoder, images, clock, _delivered = setup
    encoder.fps = 10.0
    for i in range(100):  # a 100 fps camera for 1 s
        encoder.offer(i)
        await settle(encoder)
        clock.now = 100.0 + 0.01 * (i + 1)
    gaps = [b - a for a, b in zip(images.converted, images.converted[1:], strict=False)]
    assert gaps == [5] + [10] * (len(gaps) - 1) and len(gaps) == 10, gaps  # half a period early once, then evenly


async def test_a_jittery_camera_keeps_every_frame_at_its_own_rate(setup: Any) -> None:
    """30 fps asked of a 30 fps camera whose images come up to 8 ms early or late: all 90 of 3 s are encoded (the
    old rule, 0.9 of a period since the last one, dropped each image that came 4 ms early)."""
    encoder, _images, clock, delivered = setup
    encoder.fps = 30.0
    jitter = [0.008, -0.008, 0.0, -0.006, 0.007, -0.002]
    for i in range(90):
        clock.now = 100.0 + i / 30 + jitter[i % len(jitter)]
        encoder.offer(i)
        await settle(encoder)
    assert len(delivered) == 90


async def test_two_encodes_run_at_once_and_the_newest_waits_while_both_are_busy(setup: Any) -> None:
    encoder, images, clock, delivered = setup
    encoder.fps = 1000.0
    images.gate.clear()  # the first encodes take "long"
    encoder.offer(1)
    clock.now += 0.01
    encoder.offer(2)  # a second worker takes it at once
    for i in range(3, 8):
        clock.now += 0.01
        encoder.offer(i)
    await asyncio.sleep(0.05)
    assert images.converted == [], "both encodes wait on the gate"
    images.gate.set()
    await settle(encoder)
    assert sorted(images.converted) == [1, 2, 7], "the images that arrived while both were busy: only the newest"
    stamps = [f.stamp for f in delivered]
    assert stamps == sorted(set(stamps)) and stamps[-1] == 7.0, "in order; a frame finished after a newer one: dropped"


async def test_a_frame_finished_after_a_newer_one_is_not_sent(setup: Any) -> None:
    encoder, images, clock, delivered = setup
    encoder.fps = 1000.0
    images.gates[1] = threading.Event()  # image 1 is slow to encode, image 2 quick
    encoder.offer(1)
    clock.now += 0.01
    encoder.offer(2)
    for _ in range(200):
        if delivered:
            break
        await asyncio.sleep(0.005)
    images.gates[1].set()
    await settle(encoder)
    assert sorted(images.converted) == [1, 2]
    assert [f.stamp for f in delivered] == [2.0], "image 1 finished last: dropped, never after image 2"


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
