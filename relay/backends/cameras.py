"""The live robots' cameras (``ros``, ``zenoh``): subscribed only while a client streams one or waits for a snapshot.

An image topic costs network bandwidth and a JPEG encode per frame, so a camera nobody watches is not subscribed.
Each camera's images go to its :class:`~relay.media.frame_encoder.LatestFrameEncoder` from the receiving thread (rclpy's
executor, a Zenoh callback) as the raw CDR bytes and their stamp (read in place); a worker decodes the image it
encodes (``decode``: rosbags, the pixels a view of the bytes) and the encoded frames reach the loop through the
backend's thread crossing. Neither rclpy nor zenoh is imported here: the backend passes in how to subscribe.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass
from typing import Any

from ..config import Camera, FleetConfig
from ..fleet.events import CameraError, EventSink, FrameEvent
from ..media.frame_encoder import LatestFrameEncoder
from ..ros.cdr import cdr_stamp
from ..ros.rosmsg import image_to_frame, image_type

#: A snapshot may be answered with the last frame when it is younger than this (seconds).
SNAPSHOT_MAX_AGE = 1.0
#: How long a snapshot waits for the next frame (the on-demand subscription must first be discovered).
SNAPSHOT_TIMEOUT = 5.0

#: ``subscribe(camera, callback)`` returns a subscription handle (None when there is no node or session);
#: ``unsubscribe(handle)`` destroys it.
Subscribe = Callable[[Camera, Callable[[Any], None]], Any]
Unsubscribe = Callable[[Any], None]
#: ``decode(raw, type_name)``: the message (ValueError when the bytes are not one).
Decode = Callable[[bytes, str], Any]


@dataclass
class _Camera:
    spec: Camera
    frames: LatestFrameEncoder[tuple[bytes, float]]
    subscription: Any = None
    #: Whether streamed frames need their JPEG (False: only H.264 viewers; a snapshot waiting gets one anyway).
    jpeg: bool = True


class OnDemandCameras:
    """Every camera of the fleet: its encoder, and its subscription while someone watches."""

    def __init__(
        self,
        config: FleetConfig,
        pool: Executor,
        hop: Callable[[Callable[[], None]], object],
        deliver: EventSink,
        subscribe: Subscribe,
        unsubscribe: Unsubscribe,
        decode: Decode,
    ) -> None:
        self._subscribe, self._unsubscribe = subscribe, unsubscribe
        self._cameras: dict[tuple[str, str], _Camera] = {}
        for robot in config.robots:
            for camera in robot.cameras:
                state = _Camera(camera, _encoder(robot.name, camera, pool, hop, deliver, decode, self._wants_jpeg))
                self._cameras[(robot.name, camera.name)] = state

    def _wants_jpeg(self, robot: str, camera: str) -> bool:
        """Worker thread: whether the frame being made needs a JPEG (a stream that wants one, or a snapshot)."""
        state = self._cameras[(robot, camera)]
        return state.jpeg or state.frames.waiting

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:
        self._cameras[(robot, camera)].jpeg = wanted

    def stats(self) -> dict[str, int]:
        """Images every camera's encoder replaced while both its encodes were busy, frames it dropped as older
        than one already sent (bench/bench_camera.py and bench_video.py read these)."""
        states = self._cameras.values()
        return {
            "images_replaced": sum(s.frames.replaced for s in states),
            "frames_out_of_order": sum(s.frames.out_of_order for s in states),
        }

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        self._cameras[(robot, camera)].frames.fps = fps
        if fps > 0:
            self._start(robot, camera)
        else:
            self._stop_if_idle(robot, camera)

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        frames = self._cameras[(robot, camera)].frames
        try:
            # The subscription is made once the snapshot waits, so that no image arriving first is dropped.
            return await frames.snapshot(
                SNAPSHOT_TIMEOUT, max_age=SNAPSHOT_MAX_AGE, on_wait=lambda: self._start(robot, camera)
            )
        finally:
            self._stop_if_idle(robot, camera)

    def forget_subscriptions(self) -> None:
        """The node or session they belonged to is gone (the backend is rebuilding it)."""
        for state in self._cameras.values():
            state.subscription = None

    def resubscribe(self) -> None:
        """After a rebuilt node or session: the cameras that clients stream are subscribed again."""
        for (robot, camera), state in self._cameras.items():
            if state.frames.fps > 0:
                self._start(robot, camera)

    def _start(self, robot: str, camera: str) -> None:
        state = self._cameras[(robot, camera)]
        if state.subscription is None:
            # The receiving thread: the image with its stamp, encoded only if a stream or a snapshot wants it.
            frames = state.frames

            def on_image(data: bytes) -> None:
                frames.offer((data, cdr_stamp(data, fallback=time.time())))

            state.subscription = self._subscribe(state.spec, on_image)

    def _stop_if_idle(self, robot: str, camera: str) -> None:
        state = self._cameras[(robot, camera)]
        if state.subscription is not None and state.frames.fps <= 0 and not state.frames.waiting:
            self._unsubscribe(state.subscription)
            state.subscription = None


def _encoder(
    robot: str,
    camera: Camera,
    pool: Executor,
    hop: Callable[[Callable[[], None]], object],
    deliver: EventSink,
    decode: Decode,
    wants_jpeg: Callable[[str, str], bool],
) -> LatestFrameEncoder[tuple[bytes, float]]:
    type_name = image_type(camera.compressed)

    def convert(image: tuple[bytes, float]) -> FrameEvent:
        message = decode(image[0], type_name)
        jpeg = wants_jpeg(robot, camera.name)
        return image_to_frame(robot, camera.name, image[1], message, camera.compressed, jpeg=jpeg)

    def fail(message: str) -> None:
        deliver(CameraError(robot, camera.name, message))

    return LatestFrameEncoder(f"{robot} camera {camera.name}", convert, pool, hop, deliver, fail=fail)
