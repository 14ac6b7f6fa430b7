"""Camera streams: which cameras clients want and at what rate, and the binary frames that carry them.

The backend is told the highest rate any client wants for each camera (capped at the camera's own rate) so that
a camera nobody watches costs nothing; frames are numbered per camera and encoded once for every viewer.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from .backends.base import Backend
from .config import Robot
from .description import lens_description
from .errors import CommandRejected
from .events import FrameEvent
from .hub import Channel, Hub
from .messages import FrameHeader, encode_frame
from .protocol import ErrorCode, RequestId, Stream, camera_identifier, robot_identifier, split_camera_identifier


class CameraStreams:
    def __init__(self, robots: Mapping[str, Robot], hub: Hub, backend: Backend) -> None:
        self._robots = robots
        self._hub = hub
        self._backend = backend
        self._seq: dict[str, int] = {}

    def set(self, channel: Channel, command: Stream) -> None:
        """``<robot>/stream``: start, change or (fps 0) end one client's stream; raises for an unknown camera."""
        robot = self._robots[command.robot]
        if robot.camera(command.camera) is None:
            raise CommandRejected(
                ErrorCode.NO_CAMERA,
                f"{robot_identifier(robot.name, 'stream')}: {robot.name} has no camera named {command.camera!r}",
                command.id,
            )
        identifier = camera_identifier(robot.name, command.camera)
        self._hub.set_stream(channel, identifier, command.fps)
        self.update_demand(identifier)

    def update_demand(self, identifier: str) -> None:
        robot, camera = split_camera_identifier(identifier)
        spec = self._robots[robot].camera(camera)
        if spec is not None:
            self._backend.set_stream(robot, camera, min(spec.rate, self._hub.stream_demand(identifier)))

    def streams_ended(self, identifiers: Iterable[str]) -> None:
        """A client that streamed these left: the cameras slow down or stop if nobody else watches."""
        for identifier in identifiers:
            self.update_demand(identifier)

    def encode(self, frame: FrameEvent, request_id: RequestId | None) -> bytes:
        """The binary frame of one image; ``request_id`` names the snapshot it answers (None for a stream)."""
        identifier = camera_identifier(frame.robot, frame.camera)
        seq = self._seq.get(identifier, 0) + 1
        self._seq[identifier] = seq
        header: FrameHeader = {
            "identifier": identifier,
            "seq": seq,
            "stamp": round(frame.stamp, 6),
            "encoding": "jpeg",
            "width": frame.width,
            "height": frame.height,
            "lens": lens_description(self._robots[frame.robot], frame.camera),
            "request_id": request_id,
        }
        return encode_frame(header, frame.jpeg)

    def on_frame(self, frame: FrameEvent, now: float) -> None:
        identifier = camera_identifier(frame.robot, frame.camera)
        if self._hub.stream_demand(identifier) > 0:
            self._hub.publish_frame(identifier, self.encode(frame, None), now)
