"""Camera streams: which cameras clients want, at what rate and in which codec, and the binary frames that carry them.

The backend is told the highest rate any client wants for each camera (capped at the camera's own rate) so that
a camera nobody watches costs nothing; frames are numbered per camera and encoded once for every viewer: JPEG by
the backend, H.264 by the camera's one encoder (relay/media/video_streams.py) while some client streams it as video.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable, Iterable, Mapping

from ..backends.base import Backend
from ..config import Robot
from ..errors import CommandRejected
from ..fleet.events import FrameEvent
from ..session.protocol import ErrorCode, RequestId, camera_identifier, robot_identifier, split_camera_identifier
from ..station.description import lens_description
from ..station.hub import Channel, Hub
from ..station.messages import FrameHeader, encode_frame, error_message
from ..station.outbox import Outbox
from ..wire.commands import Stream
from .video import Packet
from .video_streams import VideoStreams


class CameraStreams:
    def __init__(
        self,
        robots: Mapping[str, Robot],
        hub: Hub,
        outbox: Outbox,
        backend: Backend,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._robots = robots
        self._hub = hub
        self._outbox = outbox
        self._backend = backend
        self._seq: dict[str, int] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self.video = VideoStreams(robots, self._hop, self._publish_video, self._video_failed, clock)

    def set(self, channel: Channel, command: Stream) -> None:
        """``<robot>/stream``: start, change or (fps 0) end one client's stream; raises for an unknown camera or a
        camera that cannot be video."""
        robot = self._robots[command.robot]
        camera = robot.camera(command.camera)
        where = robot_identifier(robot.name, "stream")
        if camera is None:
            raise CommandRejected(
                ErrorCode.NO_CAMERA, f"{where}: {robot.name} has no camera named {command.camera!r}", command.id
            )
        if command.codec == "h264" and command.fps > 0 and (camera.width % 2 or camera.height % 2):
            raise CommandRejected(
                ErrorCode.UNSUPPORTED,
                f"{where}: camera {camera.name} is {camera.width}x{camera.height}; H.264 needs an even width and "
                "height: stream it as jpeg",
                command.id,
            )
        self._loop = asyncio.get_running_loop()
        identifier = camera_identifier(robot.name, command.camera)
        self._hub.set_stream(channel, identifier, command.fps, command.codec)
        if command.codec == "h264" and command.fps > 0:
            self.video.request_keyframe(identifier)  # the new viewer starts at a keyframe, now
        self.update_demand(identifier)

    def update_demand(self, identifier: str) -> None:
        robot, camera = split_camera_identifier(identifier)
        spec = self._robots[robot].camera(camera)
        if spec is not None:
            self._backend.set_stream(robot, camera, min(spec.rate, self._hub.stream_demand(identifier)))
            self._backend.set_jpeg(robot, camera, self._hub.stream_demand(identifier, "jpeg") > 0)
        if self._hub.stream_demand(identifier, "h264") <= 0:
            self.video.ended(identifier)

    def streams_ended(self, identifiers: Iterable[str]) -> None:
        """A client that streamed these left: the cameras slow down or stop if nobody else watches."""
        for identifier in identifiers:
            self.update_demand(identifier)

    def close(self) -> None:
        self.video.close()

    def _header(self, frame: FrameEvent, request_id: RequestId | None, encoding: str) -> FrameHeader:
        identifier = camera_identifier(frame.robot, frame.camera)
        seq = self._seq.get(identifier, 0) + 1
        self._seq[identifier] = seq
        return {
            "identifier": identifier,
            "seq": seq,
            "stamp": round(frame.stamp, 6),
            "encoding": encoding,
            "width": frame.width,
            "height": frame.height,
            "lens": lens_description(self._robots[frame.robot], frame.camera),
            "request_id": request_id,
        }

    def encode(self, frame: FrameEvent, request_id: RequestId | None) -> bytes:
        """The binary frame of one JPEG image; ``request_id`` names the snapshot it answers (None for a stream)."""
        return encode_frame(self._header(frame, request_id, "jpeg"), frame.jpeg)

    def on_frame(self, frame: FrameEvent, now: float) -> None:
        identifier = camera_identifier(frame.robot, frame.camera)
        if frame.jpeg and self._hub.stream_demand(identifier, "jpeg") > 0:
            self._hub.publish_frame(identifier, self.encode(frame, None), now)
        video = self._hub.stream_demand(identifier, "h264")
        if video > 0:
            self._loop = asyncio.get_running_loop()
            self.video.offer(frame, video)

    # -- video (relay.media.video_streams calls these on the loop) --------------------------------------------------

    def _publish_video(self, identifier: str, frame: FrameEvent, packet: Packet) -> tuple[int, int]:
        header = self._header(frame, None, "h264")
        header["width"], header["height"] = packet.width, packet.height
        header["keyframe"] = packet.keyframe
        header["codec"] = packet.codec
        return self._hub.publish_video(identifier, encode_frame(header, packet.data), packet.keyframe)

    def _video_failed(self, identifier: str, message: str) -> None:
        """The camera's images cannot be video: its video viewers are told, and their streams end."""
        viewers = [channel for channel in self._hub if channel.codecs.get(identifier) == "h264"]
        for channel in viewers:
            self._hub.set_stream(channel, identifier, 0)
        self._outbox.to_channels(viewers, error_message(None, ErrorCode.UNSUPPORTED, message + "; stream it as jpeg"))
        self.update_demand(identifier)

    def camera_failed(self, identifier: str, message: str) -> None:
        """A streamed camera's images cannot be read: every viewer of it (JPEG or video) is told why, by name, and
        its stream ends (the backend stops reading the camera when nobody streams it). Other cameras go on."""
        viewers = [channel for channel in self._hub if identifier in channel.streams]
        for channel in viewers:
            self._hub.set_stream(channel, identifier, 0)
        self._outbox.to_channels(viewers, error_message(None, ErrorCode.UNSUPPORTED, f"{identifier}: {message}"))
        self.update_demand(identifier)

    def _hop(self, call: Callable[[], None]) -> None:
        loop = self._loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop closed under a late encode (shutdown)
                loop.call_soon_threadsafe(call)
