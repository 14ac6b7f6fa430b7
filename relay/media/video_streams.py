"""Each camera's H.264 stream: its encoder fed with the camera's frames while some client streams it as video.

One encoder per camera, whatever the number of viewers: the hub fans its packets out (relay/station/hub.py's video
lane). Encodes run on a small pool of their own, one at a time per camera (a video encoder is a sequence: frame n+1 is
coded against frame n), the newest frame waiting while one encodes (a camera whose encoder is behind skips
frames *before* encoding, never packets after). Results come back to the loop through ``hop``.

**Keyframes.** A viewer that joins, or whose video lane had to drop a packet, waits for a keyframe (the hub
holds its packets back until one comes); the relay then asks the encoder for one, at most every
:data:`KEYFRAME_MIN_INTERVAL`, rather than waiting for the next scheduled one (relay/media/video.py, every second).

**Bitrate.** Each camera starts at its robots.yaml ``bitrate`` (default relay.media.video.default_bitrate: 2.5 Mbit/s
at 720p30). When every viewer of a camera lost a packet (their lanes were full: the link is slower than the
video), the target drops by a quarter, at most once a second, to a quarter of the configured rate at least;
after :data:`RECOVER_AFTER` seconds without a loss it climbs back by a tenth per step. That is the whole rule: no
estimate of bandwidth, only the lanes' drops, which every viewer's socket produces by itself.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from ..config import Robot
from ..fleet.events import FrameEvent
from ..session.protocol import camera_identifier
from .video import H264Encoder, Packet, VideoError

logger = logging.getLogger(__name__)

#: Seconds between two keyframes forced for viewers that wait for one (a burst of joins costs one keyframe).
KEYFRAME_MIN_INTERVAL = 0.25
#: Seconds without a lost packet before a lowered bitrate climbs again; seconds between two reductions.
RECOVER_AFTER = 5.0
REDUCE_EVERY = 1.0
#: The bitrate never goes under this share of the configured one.
MIN_BITRATE_SHARE = 0.25

#: ``publish(identifier, frame, packet) -> (viewers, waiting)``: hands a packet to the hub; how many clients stream
#: the camera as video and how many of them wait for a keyframe.
Publish = Callable[[str, FrameEvent, Packet], tuple[int, int]]
#: ``fail(identifier, message)``: the camera cannot be video (its viewers get the message, their streams end).
Fail = Callable[[str, str], None]


@dataclass
class _Camera:
    fps: float
    bitrate: int | None
    encoder: H264Encoder | None = None
    busy: bool = False
    pending: FrameEvent | None = None
    keyframe: bool = True  # the next encode starts with one (a new stream)
    last_key_request: float = -1e9
    target: int = 0  # the bitrate asked of the encoder now (0: not yet made)
    last_loss: float = -1e9
    last_change: float = -1e9
    failed: str | None = None


class VideoStreams:
    def __init__(
        self,
        robots: Mapping[str, Robot],
        hop: Callable[[Callable[[], None]], object],
        publish: Publish,
        fail: Fail,
        clock: Callable[[], float],
        *,
        workers: int = 2,
    ) -> None:
        self._robots = robots
        self._hop, self._publish, self._fail, self._clock = hop, publish, fail, clock
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="h264")
        self._cameras: dict[str, _Camera] = {}

    def offer(self, frame: FrameEvent, fps: float) -> None:
        """On the loop: a camera frame while someone streams it as video at ``fps`` (at most)."""
        identifier = camera_identifier(frame.robot, frame.camera)
        camera = self._cameras.get(identifier)
        if camera is None:
            spec = self._robots[frame.robot].camera(frame.camera)
            camera = self._cameras[identifier] = _Camera(fps=fps, bitrate=spec.bitrate if spec else None)
        if camera.failed is not None:
            return
        if camera.busy:
            camera.pending = frame  # newest wins, before encoding
            return
        camera.busy = True
        self._pool.submit(self._encode, identifier, camera, frame, camera.keyframe)
        camera.keyframe = False

    def request_keyframe(self, identifier: str) -> None:
        camera = self._cameras.get(identifier)
        now = self._clock()
        if camera is not None and now - camera.last_key_request >= KEYFRAME_MIN_INTERVAL:
            camera.last_key_request = now
            camera.keyframe = True

    def ended(self, identifier: str) -> None:
        """Nobody streams the camera as video any more: its encoder goes (a new stream starts afresh)."""
        camera = self._cameras.pop(identifier, None)
        if camera is not None and camera.encoder is not None and not camera.busy:
            camera.encoder.close()

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)

    # -- worker --------------------------------------------------------------------------------------------

    def _encode(self, identifier: str, camera: _Camera, frame: FrameEvent, keyframe: bool) -> None:
        packets: list[Packet] = []
        error: str | None = None
        try:
            bgr = frame.pixels if frame.pixels is not None else _decode_jpeg(frame)
            height, width = bgr.shape[:2]
            encoder = camera.encoder
            if encoder is None or (encoder.width, encoder.height) != (width, height):
                encoder = camera.encoder = H264Encoder(width, height, camera.fps, camera.bitrate)
                camera.target = encoder.bitrate
                keyframe = True
            elif camera.target and camera.target != encoder.bitrate:
                encoder.set_bitrate(camera.target)
            packets = encoder.encode(bgr, frame.stamp, keyframe=keyframe)
        except (VideoError, ValueError, cv2.error) as exc:
            error = f"{identifier}: {exc}"
        except Exception as exc:  # FFmpeg's own errors: the camera stops being video, the relay goes on
            logger.exception("%s: H.264 encoder failed", identifier)
            error = f"{identifier}: the H.264 encoder failed ({exc})"
        self._hop(lambda: self._done(identifier, camera, frame, packets, error))

    # -- loop -----------------------------------------------------------------------------------------------

    def _done(
        self, identifier: str, camera: _Camera, frame: FrameEvent, packets: list[Packet], error: str | None
    ) -> None:
        camera.busy = False
        if error is not None:
            camera.failed = error
            camera.pending = None
            logger.warning("%s", error)
            self._fail(identifier, error)
            return
        now = self._clock()
        for packet in packets:
            viewers, waiting = self._publish(identifier, frame, packet)
            if waiting:
                self.request_keyframe(identifier)
            if viewers and waiting == viewers and not packet.keyframe:
                camera.last_loss = now
                if now - camera.last_change >= REDUCE_EVERY:
                    self._adjust(camera, 0.75, now)
        if camera.target and now - max(camera.last_loss, camera.last_change) >= RECOVER_AFTER:
            self._adjust(camera, 1.1, now)
        if self._cameras.get(identifier) is not camera:  # ended meanwhile
            if camera.encoder is not None:
                camera.encoder.close()
            return
        if camera.pending is not None:
            pending, camera.pending = camera.pending, None
            self.offer(pending, camera.fps)

    def _adjust(self, camera: _Camera, factor: float, now: float) -> None:
        if camera.encoder is None:
            return
        configured = camera.bitrate or camera.encoder.configured
        target = int(min(configured, max(configured * MIN_BITRATE_SHARE, camera.target * factor)))
        if target != camera.target:
            logger.info("video bitrate %d -> %d bit/s (%s)", camera.target, target, "lower" if factor < 1 else "up")
            camera.target = target
        camera.last_change = now


def _decode_jpeg(frame: FrameEvent) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_COLOR)
    if image is None:
        raise VideoError(f"its frame ({len(frame.jpeg)} bytes) is not a readable JPEG")
    return image
