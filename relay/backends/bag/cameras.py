"""The recorded cameras: each one's encoder, fed the images at the playback position, a JPEG made only when wanted."""

from __future__ import annotations

import asyncio
import concurrent.futures

from ...fleet.events import CameraError, EventSink, FrameEvent
from ...media.frame_encoder import LatestFrameEncoder
from ...ros.rosmsg import image_to_frame
from .decoding import _Image

#: A snapshot waits this long for a camera's first image (s).
SNAPSHOT_TIMEOUT = 2.0


class BagCameras:
    """The cameras the bags play (added at start, once bound), converted in a small worker pool of their own."""

    def __init__(self, sink: EventSink) -> None:
        self._sink = sink
        self._cameras: dict[tuple[str, str], LatestFrameEncoder[_Image]] = {}
        #: Streamed cameras whose viewers all take H.264: their raw images are not JPEG-encoded (set_jpeg).
        self._no_jpeg: set[tuple[str, str]] = set()
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=2, thread_name_prefix="bag-jpeg")

    def add(self, robot: str, camera: str) -> None:
        """On the loop: a camera a bag plays."""
        self._cameras[(robot, camera)] = self._frame_encoder(robot, camera)

    def encoder(self, robot: str, camera: str) -> LatestFrameEncoder[_Image] | None:
        return self._cameras.get((robot, camera))

    def offer(self, image: _Image) -> None:
        frames = self._cameras.get((image.robot, image.camera))
        if frames is not None:
            frames.offer(image)

    def forget_latest(self) -> None:
        """A seek: an image from another time must not answer a snapshot."""
        for frames in self._cameras.values():
            frames.forget_latest()

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)

    def _frame_encoder(self, robot: str, camera: str) -> LatestFrameEncoder[_Image]:
        def convert(image: _Image) -> FrameEvent:
            # Worker thread: a snapshot waiting for this frame needs its JPEG whatever the stream's viewers take.
            frames = self._cameras[(robot, camera)]
            jpeg = (robot, camera) not in self._no_jpeg or frames.waiting
            return image_to_frame(image.robot, image.camera, image.stamp, image.message, image.compressed, jpeg=jpeg)

        def fail(message: str) -> None:
            self._sink(CameraError(robot, camera, message))

        loop = asyncio.get_running_loop()
        return LatestFrameEncoder(
            f"{robot} camera {camera}",
            convert,
            self._pool,
            loop.call_soon_threadsafe,
            self._sink,
            keep_latest=True,
            fail=fail,
        )

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        frames = self._cameras.get((robot, camera))
        if frames is not None:
            frames.fps = fps

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:
        if wanted:
            self._no_jpeg.discard((robot, camera))
        else:
            self._no_jpeg.add((robot, camera))

    async def snapshot(self, robot: str, camera: str, *, paused: bool) -> FrameEvent | None:
        """The JPEG of the camera's image at the playback position (also while ``paused``), or None."""
        frames = self._cameras.get((robot, camera))
        if frames is None:
            return None
        if frames.latest is None and paused:
            return None  # no image at this position, and none is coming
        return await frames.snapshot(SNAPSHOT_TIMEOUT, max_age=None, on_wait=frames.encode_latest)
