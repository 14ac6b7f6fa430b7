"""Wire protocol v1: the typed form of docs/protocol.md, with no I/O.

Text frames are JSON objects with a mandatory string ``identifier``; robot-scoped identifiers are
``<robot>/<kind>``. Binary frames carry camera images: a 4-byte big-endian header length, the header as
UTF-8 JSON, then the encoded image. This module turns client frames into typed commands (or raises
:class:`~relay.errors.ProtocolError`); ``relay.messages`` types and builds every server message. Both import
neither asyncio nor any ROS module, so they are tested without sockets, and the browser's constants, types and
identifier helpers are generated from them into ``xr_client/src/protocol.js`` (``tools/gen_protocol_js.py``).

Coordinates follow REP 103: map frame, metres, radians, quaternion ``qx, qy, qz, qw``.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Collection
from dataclasses import dataclass
from typing import Any, Final, Literal, TypeAlias

import orjson

from .errors import ProtocolError

# The fields and codes every command parser uses, re-exported: relay.protocol.ErrorCode is the protocol's word.
from .fields import MAX_COORDINATE as MAX_COORDINATE
from .fields import MAX_ID_LENGTH as MAX_ID_LENGTH
from .fields import MAX_YAW as MAX_YAW
from .fields import MISSING as _MISSING
from .fields import ErrorCode as ErrorCode
from .fields import RequestId as RequestId
from .fields import number as _number
from .fields import request_id as _request_id
from .fields import show as _show
from .fields import string as _string
from .inspection.wire import (
    INSPECTION_KINDS,
    FindingMark,
    MissionControl,
    MissionStart,
    RegionRequest,
    TargetAdd,
    inspection_identifier,
    parse_inspection,
)

PROTOCOL_VERSION: Final = 1

#: Largest text frame the relay parses; larger ones get ``too_large`` (the socket itself caps at 1 MiB).
MAX_TEXT_BYTES: Final = 64 * 1024
#: Highest camera stream rate a client may ask for.
MAX_STREAM_FPS: Final = 60.0
#: How a camera may be streamed (``<robot>/stream`` ``codec``): JPEG frames, or H.264 video (relay/video.py).
STREAM_CODECS: Final = ("jpeg", "h264")
#: A stream at ``fps`` takes a frame up to ``FRAME_SLACK`` of a period before the frame is due (:func:`take_frame`):
#: a 30 fps source whose frames come up to 8 ms early or late keeps all of them against a 30 fps request, and a
#: 60 fps one gives every other frame, evenly. The rule it
#: replaces ("0.9 of a period since the last frame taken") dropped each frame that came 4 ms early, and the
#: relay delivered 22-27 of 30 fps (bench/bench_camera.py, 2026-11-22); backends and the hub use this one.
FRAME_SLACK: Final = 0.5
#: Periods a stream that fell behind may catch up on (a burst of up to about this many frames more).
FRAME_CREDIT: Final = 2.0
#: Binary frame header length prefix: 4 bytes, big-endian unsigned.
FRAME_PREFIX: Final = struct.Struct(">I")

ROBOT_NAME_PATTERN: Final = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")


#: Robot-scoped kinds a client may send (``<robot>/<kind>``).
CLIENT_ROBOT_KINDS: Final = ("goal_pose", "cmd_vel", "cancel", "snapshot", "stream", "lease")
#: Global identifiers a client may send.
CLIENT_GLOBAL_KINDS: Final = (
    "estop",
    "ping",
    "name",
    "playback/pause",
    "playback/resume",
    "playback/seek",
    "playback/rate",
    # relay.inspection.wire.INSPECTION_KINDS:
    "mission/start",
    "mission/pause",
    "mission/resume",
    "mission/skip",
    "mission/abort",
    "finding/mark",
    "finding/update",
    "region",
    "target/add",
)
#: Playback speed factors a client may ask for (bag backend).
MIN_PLAYBACK_RATE: Final = 0.05
MAX_PLAYBACK_RATE: Final = 20.0
#: Robot-scoped kinds the server sends.
SERVER_ROBOT_KINDS: Final = ("pose", "sensor", "status", "scan", "nav", "path", "lease", "model")
#: Deepest nesting of a client message (objects and arrays); v1 messages need 2.
MAX_JSON_DEPTH: Final = 8
#: Longest string anywhere in a client message.
MAX_STRING_LENGTH: Final = 1024
#: ``cmd_vel.t``, milliseconds on the client's monotonic clock: a page open for a year stays below it.
MAX_CLIENT_CLOCK: Final = 1.0e12
#: At most this many ranges per ``<robot>/scan`` message, and at most this many messages per second.
MAX_SCAN_POINTS: Final = 360
MAX_SCAN_RATE: Final = 10.0
#: Global identifiers the server sends.
SERVER_GLOBAL_KINDS: Final = (
    "hello", "ack", "error", "pong", "estop", "scene", "playback", "backend", "targets", "targets_changed", "mission",
    "finding", "region", "operators",
)  # fmt: skip
#: Longest operator name (``name``): a person's name or a call sign.
MAX_NAME_LENGTH: Final = 40
#: Letters of any script, digits, spaces and . _ - ': nothing that could pass for markup or a control character
#: in another operator's label.
NAME_PATTERN: Final = re.compile(r"^[^\W][\w .'-]*$")

Role = Literal["operator", "viewer"]
Mode = Literal["idle", "teleop", "navigating"]

# --------------------------------------------------------------------------------------------------
# Identifiers and coalescing keys: built here, never by f-strings elsewhere
# --------------------------------------------------------------------------------------------------


def robot_identifier(robot: str, kind: str) -> str:
    """``<robot>/<kind>``: the identifier of a robot-scoped message (``robot1/pose``)."""
    return f"{robot}/{kind}"


def camera_identifier(robot: str, camera: str) -> str:
    """The identifier of a camera's binary frames and of its stream lane (``robot1/camera/front``)."""
    return f"{robot}/camera/{camera}"


def sensor_key(robot: str, name: str) -> str:
    """The coalescing key of one sensor's readings: each sensor keeps its own newest value."""
    return f"{robot}/sensor/{name}"


def take_frame(now: float, due: float, fps: float) -> float | None:
    """Whether a stream at ``fps`` takes a frame ``now``, its next frame being ``due`` (seconds; -inf: none taken
    yet): None to skip it, else when the frame after it is due. Due times advance one period per frame taken, so
    the long-run rate is at most ``fps``; a stream behind may catch up by at most :data:`FRAME_CREDIT` periods, so
    frames that arrive bunched (three 720p cameras' images come out of DDS in bursts: 18 of 29 fps got through a
    one-period credit) are kept, while a source faster than ``fps`` is thinned evenly."""
    if fps <= 0:
        return None
    period = 1.0 / fps
    if due == -math.inf:
        return now + period
    if now < due - FRAME_SLACK * period:
        return None
    return max(due, now - FRAME_CREDIT * period) + period


def split_camera_identifier(identifier: str) -> tuple[str, str]:
    """``robot1/camera/front`` -> ``("robot1", "front")``; the inverse of :func:`camera_identifier`."""
    robot, sep, camera = identifier.partition("/camera/")
    if not sep or not robot or not camera:
        raise ValueError(f"not a camera identifier: {identifier!r}")
    return robot, camera


# --------------------------------------------------------------------------------------------------
# Client -> server commands
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class GoalPose:
    robot: str
    id: RequestId
    x: float
    y: float
    yaw: float | None


@dataclass(frozen=True, slots=True)
class CmdVel:
    robot: str
    linear: float
    angular: float
    id: RequestId | None
    sent: float | None = None  # seconds on the client's own clock (``t``, milliseconds on the wire)


@dataclass(frozen=True, slots=True)
class Cancel:
    robot: str
    id: RequestId


@dataclass(frozen=True, slots=True)
class Snapshot:
    robot: str
    id: RequestId
    camera: str | None


@dataclass(frozen=True, slots=True)
class Stream:
    robot: str
    id: RequestId
    camera: str
    fps: float
    codec: str = "jpeg"


@dataclass(frozen=True, slots=True)
class EStop:
    """Stop (and latch) every robot or one; ``reset`` lifts the latch (the robots stay stopped)."""

    id: RequestId
    robot: str | None
    action: Literal["stop", "reset"] = "stop"


@dataclass(frozen=True, slots=True)
class Ping:
    t: float


@dataclass(frozen=True, slots=True)
class Name:
    """The name this client goes by, shown to other operators instead of its connection id."""

    id: RequestId
    name: str


@dataclass(frozen=True, slots=True)
class Playback:
    """Control of a recording's replay: ``pause``, ``resume``, ``seek`` (to ``value`` s) or ``rate``."""

    id: RequestId
    action: Literal["pause", "resume", "seek", "rate"]
    value: float | None


@dataclass(frozen=True, slots=True)
class Lease:
    """Take (``acquire``, with ``force`` to take over from another operator) or give back a robot."""

    robot: str
    id: RequestId
    action: Literal["acquire", "release"]
    force: bool


def peek_request_id(obj: object) -> RequestId | None:
    """Best-effort ``id`` of a message that failed validation, so its ``error`` can name it."""
    if not isinstance(obj, dict):
        return None
    try:
        return _request_id(obj, required=False)
    except ProtocolError:
        return None


def decode_json(data: str | bytes) -> dict[str, Any]:
    """Parse one text frame into a JSON object, or raise ``bad_request`` / ``too_large``."""
    size = len(data.encode() if isinstance(data, str) else data)
    if size > MAX_TEXT_BYTES:
        raise ProtocolError(
            ErrorCode.TOO_LARGE, f"text frame of {size} bytes exceeds the limit of {MAX_TEXT_BYTES} bytes"
        )
    try:
        obj = orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"frame is not valid JSON: {exc}") from None
    if not isinstance(obj, dict):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"frame must be a JSON object, got {type(obj).__name__}")
    _check_shape(obj)
    return obj


def _check_shape(obj: object) -> None:
    """Bound nesting and string lengths, iteratively (a deep document must not recurse here either)."""
    stack: list[tuple[object, int]] = [(obj, 1)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, str):
            if len(value) > MAX_STRING_LENGTH:
                raise ProtocolError(
                    ErrorCode.BAD_REQUEST, f"a string of {len(value)} characters exceeds {MAX_STRING_LENGTH}"
                )
            continue
        if isinstance(value, dict | list):
            if depth > MAX_JSON_DEPTH:
                raise ProtocolError(ErrorCode.BAD_REQUEST, f"message nested deeper than {MAX_JSON_DEPTH} levels")
            items = value.items() if isinstance(value, dict) else enumerate(value)
            for key, item in items:
                if isinstance(key, str) and len(key) > MAX_STRING_LENGTH:
                    raise ProtocolError(ErrorCode.BAD_REQUEST, f"a key exceeds {MAX_STRING_LENGTH} characters")
                stack.append((item, depth + 1))


def parse_command(data: str | bytes, robots: Collection[str]) -> Command:
    """Validate one client text frame and return its command.

    ``robots`` are the configured robot names. Raises :class:`ProtocolError` carrying the message's ``id``
    when it could be read; the caller replies with ``error`` and keeps the connection open.
    """
    obj = decode_json(data)
    try:
        return _parse_object(obj, robots)
    except ProtocolError as exc:
        if exc.request_id is None:
            exc.request_id = peek_request_id(obj)
        identifier = obj.get("identifier")
        exc.identifier = identifier[:80] if isinstance(identifier, str) else None
        raise


def command_identifier(command: Command) -> str:
    """The identifier a command arrived with."""
    if isinstance(command, Ping):
        return "ping"
    if isinstance(command, EStop):
        return "estop"
    if isinstance(command, Name):
        return "name"
    if isinstance(command, Playback):
        return f"playback/{command.action}"
    if isinstance(command, InspectionCommands):
        return inspection_identifier(command)
    kind = {
        GoalPose: "goal_pose",
        CmdVel: "cmd_vel",
        Cancel: "cancel",
        Snapshot: "snapshot",
        Stream: "stream",
        Lease: "lease",
    }
    return robot_identifier(command.robot, kind[type(command)])


def _parse_object(obj: dict[str, Any], robots: Collection[str]) -> Command:
    identifier = obj.get("identifier", _MISSING)
    if identifier is _MISSING:
        raise ProtocolError(ErrorCode.BAD_REQUEST, "message has no 'identifier' field")
    if not isinstance(identifier, str):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"'identifier' must be a string, got {_show(identifier)}")

    if identifier == "ping":
        t = _number(obj, "t", identifier)
        assert t is not None
        return Ping(t=t)
    if identifier == "estop":
        rid = _request_id(obj, required=True)
        assert rid is not None
        robot = _string(obj, "robot", identifier, required=False)
        if robot is not None and robot not in robots:
            raise ProtocolError(ErrorCode.UNKNOWN_ROBOT, f"estop: unknown robot {robot!r}", rid)
        action = obj.get("action", "stop")
        if action not in ("stop", "reset"):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST, f"estop: field 'action' must be 'stop' or 'reset', got {_show(action)}", rid
            )
        return EStop(id=rid, robot=robot, action=action)

    if identifier == "name":
        rid = _request_id(obj, required=True)
        assert rid is not None
        raw = _string(obj, "name", identifier, required=True)
        name = " ".join((raw or "").split())
        if not name or len(name) > MAX_NAME_LENGTH or not NAME_PATTERN.match(name):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST,
                f"name: {_show(raw)} cannot be a name: letters, digits, spaces and . _ - ' only, "
                f"1 to {MAX_NAME_LENGTH} characters",
                rid,
            )
        return Name(id=rid, name=name)
    if identifier in ("playback/pause", "playback/resume", "playback/seek", "playback/rate"):
        rid = _request_id(obj, required=True)
        assert rid is not None
        action = identifier.partition("/")[2]
        value = None
        if action == "seek":
            value = _number(obj, "t", identifier, low=0.0)
        elif action == "rate":
            value = _number(obj, "rate", identifier, low=MIN_PLAYBACK_RATE, high=MAX_PLAYBACK_RATE)
        return Playback(id=rid, action=action, value=value)  # type: ignore[arg-type]
    if identifier in INSPECTION_KINDS:
        return parse_inspection(obj, identifier)

    robot, sep, kind = identifier.partition("/")
    if not sep or kind not in CLIENT_ROBOT_KINDS:
        raise ProtocolError(
            ErrorCode.UNKNOWN_IDENTIFIER,
            f"unknown identifier {_show(identifier)}; expected one of "
            + ", ".join([*CLIENT_GLOBAL_KINDS, *(f"<robot>/{k}" for k in CLIENT_ROBOT_KINDS)]),
        )
    if robot not in robots:
        raise ProtocolError(
            ErrorCode.UNKNOWN_ROBOT,
            # Both are the client's own text: shown clipped, so an error (and its audit record) stays short.
            f"{_show(identifier)}: unknown robot {_show(robot)}; the fleet is " + ", ".join(sorted(robots)),
        )

    if kind == "cmd_vel":
        linear = _number(obj, "linear", identifier)
        angular = _number(obj, "angular", identifier)
        assert linear is not None and angular is not None
        sent = _number(obj, "t", identifier, required=False, low=0.0, high=MAX_CLIENT_CLOCK)
        return CmdVel(
            robot=robot,
            linear=linear,
            angular=angular,
            id=_request_id(obj, required=False),
            sent=None if sent is None else sent / 1000.0,
        )

    rid = _request_id(obj, required=True)
    assert rid is not None
    if kind == "goal_pose":
        x = _number(obj, "x", identifier, low=-MAX_COORDINATE, high=MAX_COORDINATE)
        y = _number(obj, "y", identifier, low=-MAX_COORDINATE, high=MAX_COORDINATE)
        assert x is not None and y is not None
        # Any finite yaw means something (it wraps), but not astronomically large ones: they are mistakes.
        yaw = _number(obj, "yaw", identifier, required=False, low=-MAX_YAW, high=MAX_YAW)
        return GoalPose(robot=robot, id=rid, x=x, y=y, yaw=yaw)
    if kind == "cancel":
        return Cancel(robot=robot, id=rid)
    if kind == "lease":
        action = obj.get("action", "acquire")
        if action not in ("acquire", "release"):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST,
                f"{identifier}: field 'action' must be 'acquire' or 'release', got {_show(action)}",
            )
        force = obj.get("force", False)
        if not isinstance(force, bool):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: field 'force' must be true or false")
        return Lease(robot=robot, id=rid, action=action, force=force)
    if kind == "snapshot":
        return Snapshot(robot=robot, id=rid, camera=_string(obj, "camera", identifier, required=False))
    # kind == "stream"
    camera = _string(obj, "camera", identifier, required=True)
    fps = _number(obj, "fps", identifier, low=0.0, high=MAX_STREAM_FPS)
    codec = _string(obj, "codec", identifier, required=False) or "jpeg"
    assert camera is not None and fps is not None
    if codec not in STREAM_CODECS:
        raise ProtocolError(
            ErrorCode.UNSUPPORTED,
            f"{identifier}: codec {_show(codec)} is not offered; cameras stream as " + " or ".join(STREAM_CODECS),
            rid,
        )
    return Stream(robot=robot, id=rid, camera=camera, fps=fps, codec=codec)


InspectionCommands: Final = (MissionStart, MissionControl, FindingMark, RegionRequest, TargetAdd)
Command: TypeAlias = (
    GoalPose | CmdVel | Cancel | Snapshot | Stream | EStop | Ping | Name | Playback | Lease
    | MissionStart | MissionControl | FindingMark | RegionRequest | TargetAdd
)  # fmt: skip
