"""The station's own client commands (docs/protocol.md), each declared once: driving, cameras, leases, estop,
names, playback and the clock. Features declare theirs beside their code (relay/inspection/wire.py).

Coordinates follow REP 103: map frame, metres, radians.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, Final, Literal

from ..errors import ProtocolError
from .declare import (
    Forms,
    Frame,
    WireCommand,
    choice,
    command,
    custom,
    derived,
    flag,
    from_identifier,
    real,
    request,
    text,
)
from .fields import MAX_COORDINATE, MAX_YAW, ErrorCode, RequestId, number, show, string

#: Highest camera stream rate a client may ask for.
MAX_STREAM_FPS: Final = 60.0
#: How a camera may be streamed (``<robot>/stream`` ``codec``): JPEG frames, or H.264 video (relay/media/video.py).
STREAM_CODECS: Final = ("jpeg", "h264")
#: Playback speed factors a client may ask for (bag backend).
MIN_PLAYBACK_RATE: Final = 0.05
MAX_PLAYBACK_RATE: Final = 20.0
#: ``cmd_vel.t``, milliseconds on the client's monotonic clock: a page open for a year stays below it.
MAX_CLIENT_CLOCK: Final = 1.0e12
#: Longest operator name (``name``): a person's name or a call sign.
MAX_NAME_LENGTH: Final = 40
#: Letters of any script, digits, spaces and . _ - ': nothing that could pass for markup or a control character
#: in another operator's label.
NAME_PATTERN: Final = re.compile(r"^[^\W][\w .'-]*$")


@command("<robot>/goal_pose")
@dataclass(frozen=True, slots=True)
class GoalPose(WireCommand):
    robot: str = from_identifier()
    id: RequestId = request()
    x: float = real(low=-MAX_COORDINATE, high=MAX_COORDINATE)
    y: float = real(low=-MAX_COORDINATE, high=MAX_COORDINATE)
    # Any finite yaw means something (it wraps), but not astronomically large ones: they are mistakes.
    yaw: float | None = real(required=False, low=-MAX_YAW, high=MAX_YAW, js="number | null")


@command("<robot>/cmd_vel")
@dataclass(frozen=True, slots=True)
class CmdVel(WireCommand):
    robot: str = from_identifier()
    linear: float = real()
    angular: float = real()
    id: RequestId | None = request(required=False)
    # Seconds on the client's own clock; on the wire ``t``, milliseconds of performance.now(): how old it is.
    sent: float | None = real(key="t", required=False, low=0.0, high=MAX_CLIENT_CLOCK, scale=0.001)


@command("<robot>/cancel")
@dataclass(frozen=True, slots=True)
class Cancel(WireCommand):
    robot: str = from_identifier()
    id: RequestId = request()


@command("<robot>/snapshot")
@dataclass(frozen=True, slots=True)
class Snapshot(WireCommand):
    robot: str = from_identifier()
    id: RequestId = request()
    camera: str | None = text(required=False)


@command("<robot>/stream")
@dataclass(frozen=True, slots=True)
class Stream(WireCommand):
    """A camera's stream at ``fps`` (0 stops it), as JPEG frames or H.264 (when hello's cameras offer it)."""

    robot: str = from_identifier()
    id: RequestId = request()
    camera: str = text()
    fps: float = real(low=0.0, high=MAX_STREAM_FPS)
    codec: str = choice(
        STREAM_CODECS,
        default="jpeg",
        code=ErrorCode.UNSUPPORTED,
        says="is not offered; cameras stream as " + " or ".join(STREAM_CODECS),
    )


@command("<robot>/lease")
@dataclass(frozen=True, slots=True)
class Lease(WireCommand):
    """Take (``acquire``, with ``force`` to take over from another operator) or give back a robot."""

    robot: str = from_identifier()
    id: RequestId = request()
    action: Literal["acquire", "release"] = choice(("acquire", "release"), default="acquire")
    force: bool = flag()


@command("estop")
@dataclass(frozen=True, slots=True)
class EStop(WireCommand):
    """Stop (and latch) every robot or one; ``reset`` lifts the latch (the robots stay stopped)."""

    id: RequestId = request()
    robot: str | None = text(required=False)
    action: Literal["stop", "reset"] = choice(("stop", "reset"), default="stop")

    def check(self, frame: Frame) -> None:
        if self.robot is not None and self.robot not in frame.robots:
            raise ProtocolError(ErrorCode.UNKNOWN_ROBOT, f"estop: unknown robot {self.robot!r}", self.id)


@command("ping")
@dataclass(frozen=True, slots=True)
class Ping(WireCommand):
    t: float = real()


def _operator_name(value: Any, field: str, identifier: str) -> str:
    raw = string({field: value}, field, identifier, required=True) or ""
    name = " ".join(raw.split())
    if not name or len(name) > MAX_NAME_LENGTH or not NAME_PATTERN.match(name):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"name: {show(raw)} cannot be a name: letters, digits, spaces and . _ - ' only, "
            f"1 to {MAX_NAME_LENGTH} characters",
        )
    return name


@command("name")
@dataclass(frozen=True, slots=True)
class Name(WireCommand):
    """The name this client goes by, shown to other operators instead of its connection id."""

    id: RequestId = request()
    name: str = custom(_operator_name, "string", required=True)


def _playback_value(obj: Mapping[str, Any], frame: Frame) -> float | None:
    """Where a seek goes (``t``, s) or the rate of a rate change; None for pause and resume."""
    if frame.suffix == "seek":
        return number(obj, "t", frame.identifier, low=0.0)
    if frame.suffix == "rate":
        return number(obj, "rate", frame.identifier, low=MIN_PLAYBACK_RATE, high=MAX_PLAYBACK_RATE)
    return None


@command("playback/pause", "playback/resume", "playback/seek", "playback/rate")
@dataclass(frozen=True, slots=True)
class Playback(WireCommand):
    """Control of a recording's replay: ``pause``, ``resume``, ``seek`` (to ``value`` s) or ``rate``."""

    FORMS: ClassVar[Forms] = {
        "PlaybackCommand": (("playback/pause", "playback/resume"), (), ()),
        "PlaybackSeekCommand": (("playback/seek",), ("t: number",), ()),
        "PlaybackRateCommand": (("playback/rate",), ("rate: number",), ()),
    }
    id: RequestId = request()
    action: Literal["pause", "resume", "seek", "rate"] = from_identifier()
    value: float | None = derived(_playback_value)


#: The station's own commands, in the order docs/protocol.md lists them.
STATION_COMMANDS: Final = (GoalPose, CmdVel, Cancel, Snapshot, Stream, Lease, EStop, Ping, Name, Playback)
StationCommand = GoalPose | CmdVel | Cancel | Snapshot | Stream | Lease | EStop | Ping | Name | Playback
