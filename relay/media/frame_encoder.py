"""One camera's images to JPEG frames, for every backend: two encodes in flight, newest wins, throttled, snapshots.

A camera delivers images faster than anyone may look at them, and a JPEG encode of a 720p image costs
milliseconds of a worker thread. So per camera, whatever the number of viewers (the hub fans the one frame out):

- an image is encoded only when a client streams the camera (at most at the stream's rate,
  :func:`relay.session.protocol.take_frame`) or a snapshot waits;
- up to :data:`IN_FLIGHT` encodes run at a time, on different workers of the pool: with one, an image that came
  while the previous one was still being encoded waited for it, and when the pool was shared by three 720p cameras
  the next image often replaced it, so a camera lost frames that the two cores had time for. An image that arrives
  while both are busy replaces any other waiting one (newest wins only when the pool is behind), so a slow
  encoder never builds a backlog; a frame finished after a newer one of the same camera is dropped, never sent
  out of order;
- a snapshot takes the last frame when it is recent enough (or made from the newest image), else waits for the
  next one.

``offer`` may be called from any thread (the ros backend's executor thread, the bag backend's loop); the encode
runs in the backend's worker pool; its result reaches the loop through ``hop`` (the backend's one thread
crossing), where :meth:`LatestFrameEncoder.done` hands the frame on and wakes snapshot waiters.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor
from typing import Generic, TypeVar

from ..fleet.events import FrameEvent
from ..session.protocol import take_frame
from .imaging import ImageError

logger = logging.getLogger(__name__)

#: Encodes of one camera that may run at once.
IN_FLIGHT = 2

Image = TypeVar("Image")


class LatestFrameEncoder(Generic[Image]):
    """The frames of one camera. ``convert`` turns an image into a frame (worker thread)."""

    def __init__(
        self,
        name: str,
        convert: Callable[[Image], FrameEvent],
        pool: Executor,
        hop: Callable[[Callable[[], None]], object],
        deliver: Callable[[FrameEvent], None],
        clock: Callable[[], float] = time.monotonic,
        *,
        keep_latest: bool = False,
        fail: Callable[[str], None] | None = None,
    ) -> None:
        self.name = name
        self._convert, self._pool, self._hop, self._deliver = convert, pool, hop, deliver
        #: Told (on the loop) why an image of a streamed camera could not be read: its viewers hear it.
        self._fail = fail
        self._clock, self._keep_latest = clock, keep_latest
        self._lock = threading.Lock()
        #: The stream rate clients ask for (0: nobody streams this camera).
        self.fps = 0.0
        self._due = -float("inf")  # when the stream's next frame is due
        self._in_flight = 0  # encodes submitted and not finished
        self._submitted = 0  # sequence number of the last image submitted
        self._delivered = 0  # ... and of the last frame delivered (the loop's; older results are dropped)
        self._in_transit = 0  # results handed to ``hop`` that ``done`` has not received yet
        #: Images replaced while waiting for a free encode, and frames dropped for finishing after a newer one.
        self.replaced = 0
        self.out_of_order = 0
        self._pending: Image | None = None
        #: The newest image offered, with ``keep_latest`` (a recording: a snapshot of a paused replay encodes it;
        #: a live camera keeps none, its next image is at most a frame away).
        self.latest: Image | None = None
        self.last: FrameEvent | None = None
        self._last_of: Image | None = None
        self._last_time = -float("inf")
        self._waiters: list[asyncio.Future[FrameEvent | None]] = []

    @property
    def encoding(self) -> bool:
        """An encode is in flight (or its result is still on its way to the loop)."""
        return self._in_flight > 0 or self._in_transit > 0

    @property
    def waiting(self) -> bool:
        """A snapshot waits for the next frame (read across threads: a length, atomic)."""
        return bool(self._waiters)

    def offer(self, image: Image) -> None:
        """A new image: encode it if a stream is due one or a snapshot waits; else only remember it."""
        with self._lock:
            if self._keep_latest:
                self.latest = image
            after = take_frame(self._clock(), self._due, self.fps)
            if after is not None:
                self._due = after
            elif not self._waiters:
                return  # faster than anyone asked for: do not spend a JPEG encode on it
            self._start(image)

    def encode_latest(self) -> None:
        """Encode the newest image now (a snapshot of a camera that is not streaming)."""
        with self._lock:
            if self.latest is not None:
                self._start(self.latest)

    def forget_latest(self) -> None:
        """The newest image is no longer current (a replay jumped): it must not answer a snapshot."""
        with self._lock:
            self.latest = None
            self._pending = None

    def _start(self, image: Image) -> None:
        """Under the lock: encode ``image``, or keep it for when an encode in flight is done."""
        if self._in_flight >= IN_FLIGHT:
            if self._pending is not None:
                self.replaced += 1
            self._pending = image
            return
        self._in_flight += 1
        self._submitted += 1
        self._pool.submit(self._work, image, self._submitted)

    def _work(self, image: Image, sequence: int) -> None:
        """Worker thread: convert, hand the result to the loop, then take the newest pending image."""
        while True:
            frame: FrameEvent | None = None
            error: str | None = None
            try:
                frame = self._convert(image)
            except (ImageError, ValueError) as exc:
                logger.warning("%s: %s", self.name, exc)
                error = str(exc)
            with self._lock:
                self._in_transit += 1
            self._hop(lambda f=frame, i=image, n=sequence, e=error: self.done(f, i, n, e))  # type: ignore[misc]
            with self._lock:
                if self._pending is None:
                    self._in_flight -= 1
                    return
                image, self._pending = self._pending, None
                self._submitted += 1
                sequence = self._submitted

    def done(self, frame: FrameEvent | None, image: Image, sequence: int, error: str | None = None) -> None:
        """On the loop: a frame (or None: the image could not be read, ``error`` says why) is ready; ``sequence``
        orders the images submitted (a frame older than one already delivered is dropped)."""
        with self._lock:
            self._in_transit = max(0, self._in_transit - 1)
        if frame is None and error is not None and self.fps > 0 and self._fail is not None:
            self._fail(error)
        if frame is not None:
            if sequence < self._delivered:
                self.out_of_order += 1
                return  # a newer frame of this camera went out first: never send one out of order
            self._delivered = sequence
        if frame is not None:
            self._deliver(frame)
            if not frame.jpeg:
                return  # made for H.264 viewers only: a waiting snapshot takes the next, made with its JPEG
            self.last, self._last_of, self._last_time = frame, image, self._clock()
        for waiter in self._waiters:
            if not waiter.done():
                waiter.set_result(frame)
        self._waiters.clear()

    async def snapshot(
        self, wait: float, *, max_age: float | None, on_wait: Callable[[], None] | None = None
    ) -> FrameEvent | None:
        """The last frame when it is younger than ``max_age`` or (``keep_latest``) made from the newest image;
        else the next one, waited for at most ``wait`` seconds (None when none comes in time).

        ``on_wait`` runs once the snapshot waits, so that nothing offered after it is dropped: it subscribes a
        live camera, or encodes a recording's newest image at once (:meth:`encode_latest`).
        """
        last = self.last
        if last is not None:
            fresh = max_age is not None and self._clock() - self._last_time < max_age
            if fresh or (self._keep_latest and self._last_of is self.latest):
                return last
        waiter: asyncio.Future[FrameEvent | None] = asyncio.get_running_loop().create_future()
        self._waiters.append(waiter)
        if on_wait is not None:
            on_wait()
        try:
            return await asyncio.wait_for(waiter, wait)
        except TimeoutError:
            return None
        finally:
            if waiter in self._waiters:
                self._waiters.remove(waiter)
