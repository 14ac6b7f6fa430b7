"""Server messages of wire protocol v1: one TypedDict per kind (mirroring docs/protocol.md) and its builder.

Each builder returns the message whose bytes tests pin (tests/test_protocol.py); ``encode`` turns it into the
text frame every interested client receives, encoded once. No I/O; the browser's types are generated from these
(``tools/gen_protocol_js.py`` -> ``xr_client/src/protocol.js``). A feature's messages are its own
(relay/inspection/messages.py); relay/station/messages.py gathers them all.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Final, Literal, TypeAlias, TypedDict, cast

import numpy as np
import orjson

from .descriptions import (
    GoalDescription,
    RobotDescription,
    RoomDescription,
    SceneDescription,
    Transform2D,
    VantageDescription,
)
from .fields import RequestId
from .identifiers import robot_identifier, sensor_key

#: What a client may do (relay/accounts/roles.py): an account's role, or the token's operator and a tokenless viewer.
Role = Literal["admin", "operator", "inspector", "viewer"]
Mode = Literal["idle", "teleop", "navigating"]


class PoseMessage(TypedDict):
    identifier: str
    stamp: float
    frame: str
    x: float
    y: float
    z: float
    qx: float
    qy: float
    qz: float
    qw: float
    yaw: float


class SensorMessage(TypedDict):
    identifier: str
    name: str
    value: float
    unit: str
    warning: bool
    stamp: float


class StatusMessage(TypedDict):
    identifier: str
    online: bool
    age: float | None
    mode: Mode
    goal: GoalDescription | None
    controller: str | None
    estopped: bool


class ScanMessage(TypedDict):
    identifier: str
    stamp: float
    frame: str
    angle_min: float
    angle_increment: float
    range_max: float
    ranges: list[float | None]


NavOutcome: TypeAlias = Literal["started", "reached", "failed", "cancelled"]


class NavFeedback(TypedDict):
    distance_remaining: float  # metres
    eta: float  # seconds, Nav2's estimate
    recoveries: int
    navigation_time: float  # seconds since the goal started


class NavMessage(TypedDict):
    identifier: str
    outcome: NavOutcome
    goal: GoalDescription | None
    message: str
    error_code: int | None
    feedback: NavFeedback | None
    confirmed: bool | None


class PathMessage(TypedDict):
    identifier: str
    points: list[list[float]]


class OperatorsMessage(TypedDict):
    identifier: Literal["operators"]
    names: dict[str, str]


class RobotState(TypedDict):
    pose: PoseMessage | None
    sensors: dict[str, SensorMessage]
    status: StatusMessage


class ServerInfo(TypedDict):
    name: str
    version: str


class AckMessage(TypedDict):
    identifier: Literal["ack"]
    id: RequestId


class ErrorMessage(TypedDict):
    identifier: Literal["error"]
    id: RequestId | None
    code: str  # one of ErrorCode.ALL
    message: str


class PongMessage(TypedDict):
    identifier: Literal["pong"]
    t: float
    server_time: float


class BackendMessage(TypedDict):
    identifier: Literal["backend"]
    name: str
    ok: bool
    message: str | None


class ModelMessage(TypedDict):
    identifier: str  # <robot>/model
    url: str


class SceneMessage(TypedDict):
    identifier: Literal["scene"]
    url: str | None
    map_to_scene: Transform2D


class PlaybackMessage(TypedDict):
    identifier: Literal["playback"]
    position: float
    duration: float
    rate: float
    paused: bool
    loop: bool


LeaseReason = Literal["acquired", "released", "taken_over", "expired", "disconnected"]


class LeaseMessage(TypedDict):
    identifier: str  # <robot>/lease
    holder: str | None
    previous: str | None
    reason: LeaseReason


class EstopMessage(TypedDict):
    identifier: Literal["estop"]
    robots: list[str]
    by: str | None
    latched: bool


class HelloMessage(TypedDict):
    identifier: Literal["hello"]
    protocol: int
    server: ServerInfo
    client_id: str
    role: Role
    scene: SceneDescription
    bounds: list[float] | None
    vantage: VantageDescription | None
    rooms: list[RoomDescription]
    robots: list[RobotDescription]
    state: dict[str, RobotState]
    playback: PlaybackMessage | None
    backend: BackendMessage


class VoxelMapMessage(TypedDict):
    """The live 3D map's news (issue #33): ``blocks`` block records follow in ``frames`` binary frames, taking a
    client that held the map at ``since`` (0: nothing) to ``version``; ``reset``: drop every block held first."""

    identifier: Literal["voxel_map"]
    version: int
    since: int
    reset: bool
    voxel: float
    blocks: int
    frames: int


#: Every message the station's own parts send as a text frame (relay/station/messages.py adds the features').
StationMessage = (
    HelloMessage
    | PoseMessage
    | SensorMessage
    | StatusMessage
    | ScanMessage
    | NavMessage
    | PathMessage
    | AckMessage
    | ErrorMessage
    | PongMessage
    | EstopMessage
    | SceneMessage
    | PlaybackMessage
    | BackendMessage
    | LeaseMessage
    | ModelMessage
    | OperatorsMessage
    | VoxelMapMessage
)

#: The messages of a client's state lane (relay/station/hub.py): a slow client gets only the newest of each coalescing
#: key.
StateMessage = (
    PoseMessage
    | SensorMessage
    | StatusMessage
    | ScanMessage
    | NavMessage
    | PathMessage
    | SceneMessage
    | PlaybackMessage
)


def state_key(message: StateMessage) -> str:
    """The coalescing key of a state message, for ``Hub.publish_state``: its identifier, except that each sensor
    of a robot keeps its own newest reading (``relay.session.protocol.sensor_key``), as docs/protocol.md promises."""
    identifier = message["identifier"]
    if identifier == "avatar":  # a replay's operators (relay/wire/viewer.py): each keeps their newest viewpoint
        return f"avatar/{cast(Mapping[str, Any], message)['client']}"
    robot, _, kind = identifier.partition("/")
    if kind == "sensor":
        return sensor_key(robot, cast(SensorMessage, message)["name"])
    return identifier


# --------------------------------------------------------------------------------------------------
# Encoding: each function returns the exact bytes of one text frame
# --------------------------------------------------------------------------------------------------


def encode(message: StationMessage | Mapping[str, Any]) -> bytes:
    """Encode one message as it goes on the wire (UTF-8 JSON, keys in the documented order)."""
    return orjson.dumps(message)


def pose_message(
    robot: str,
    *,
    stamp: float,
    frame: str,
    x: float,
    y: float,
    z: float,
    qx: float,
    qy: float,
    qz: float,
    qw: float,
) -> PoseMessage:
    # Rounding to 0.1 mm and 1e-6 keeps frames short without losing anything a twin can show.
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return {
        "identifier": robot_identifier(robot, "pose"),
        "stamp": round(stamp, 6),
        "frame": frame,
        "x": round(x, 4),
        "y": round(y, 4),
        "z": round(z, 4),
        "qx": round(qx, 6),
        "qy": round(qy, 6),
        "qz": round(qz, 6),
        "qw": round(qw, 6),
        "yaw": round(yaw, 6),
    }


def sensor_message(robot: str, *, name: str, value: float, unit: str, warning: bool, stamp: float) -> SensorMessage:
    return {
        "identifier": robot_identifier(robot, "sensor"),
        "name": name,
        "value": round(value, 4),
        "unit": unit,
        "warning": warning,
        "stamp": round(stamp, 6),
    }


def status_message(
    robot: str,
    *,
    online: bool,
    age: float | None,
    mode: Mode,
    goal: GoalDescription | None,
    controller: str | None,
    estopped: bool = False,
) -> StatusMessage:
    """``estopped``: the robot's emergency stop is latched; motion commands are refused until it is reset."""
    return {
        "identifier": robot_identifier(robot, "status"),
        "online": online,
        "age": None if age is None else round(age, 3),
        "mode": mode,
        "goal": goal,
        "controller": controller,
        "estopped": estopped,
    }


def nav_message(
    robot: str,
    *,
    outcome: NavOutcome,
    goal: GoalDescription | None,
    message: str,
    error_code: int | None = None,
    feedback: NavFeedback | None = None,
    confirmed: bool | None = None,
) -> NavMessage:
    """How a goal went: ``started`` (planned, followed; with Nav2's ``feedback`` while it runs), ``reached``,
    ``failed`` (the message says why; ``error_code``: Nav2's) or ``cancelled`` (cancel, teleop, an estop, a newer
    goal; ``confirmed``: the navigator's answer to the relay's cancel, once it came or did not within 1 s)."""
    if feedback is not None:
        feedback = {
            "distance_remaining": round(feedback["distance_remaining"], 2),
            "eta": round(feedback["eta"], 1),
            "recoveries": feedback["recoveries"],
            "navigation_time": round(feedback["navigation_time"], 1),
        }
    return {
        "identifier": robot_identifier(robot, "nav"),
        "outcome": outcome,
        "goal": goal,
        "message": message,
        "error_code": error_code,
        "feedback": feedback,
        "confirmed": confirmed,
    }


#: Most points a path message carries: a longer plan (Nav2 plans at the costmap's resolution, thousands of points)
#: is thinned evenly, keeping its ends; centimetres and a few hundred points draw a path faithfully.
MAX_PATH_POINTS: Final = 400


def path_message(robot: str, points: Sequence[tuple[float, float]]) -> PathMessage:
    """The robot's planned path to its goal, map frame; empty when it has none."""
    if len(points) > MAX_PATH_POINTS:
        step = (len(points) - 1) / (MAX_PATH_POINTS - 1)
        points = [points[round(i * step)] for i in range(MAX_PATH_POINTS)]
    return {"identifier": robot_identifier(robot, "path"), "points": [[round(x, 2), round(y, 2)] for x, y in points]}


def operators_message(names: Mapping[str, str]) -> OperatorsMessage:
    """Who is connected by name: client id -> the name it gave (clients without one are left out)."""
    return {"identifier": "operators", "names": dict(sorted(names.items()))}


def scan_message(
    robot: str,
    *,
    stamp: float,
    frame: str,
    angle_min: float,
    angle_increment: float,
    range_max: float,
    ranges: tuple[float, ...] | list[float],
) -> ScanMessage:
    # Centimetres are plenty for drawing obstacles; null marks a beam with no valid return: NaN and infinities
    # stay floats here and orjson writes them as null. Rounded by numpy: 360 beams took ~70 us as a Python loop,
    # 12 us so; at 100 robots x 10 Hz the loop was a quarter of the relay's core (bench/bench_ros_ingest.py).
    return {
        "identifier": robot_identifier(robot, "scan"),
        "stamp": round(stamp, 6),
        "frame": frame,
        "angle_min": round(angle_min, 6),
        "angle_increment": round(angle_increment, 6),
        "range_max": round(range_max, 3),
        "ranges": np.round(np.asarray(ranges, dtype=np.float64), 2).tolist(),
    }


def ack_message(request_id: RequestId) -> AckMessage:
    return {"identifier": "ack", "id": request_id}


#: No text the relay writes to a client is longer (docs/security.md): an error once echoed 139 kB of target ids.
MAX_TEXT = 400


def clip(text: str, limit: int = MAX_TEXT) -> str:
    """``text`` cut to ``limit`` characters, the cut marked."""
    return text if len(text) <= limit else text[: limit - 1] + "…"


def error_message(request_id: RequestId | None, code: str, message: str) -> ErrorMessage:
    # Clipped here, where every error is made: whatever an error path puts in, no client gets a long one.
    return {"identifier": "error", "id": request_id, "code": code, "message": clip(message)}


def pong_message(t: float, server_time: float) -> PongMessage:
    return {"identifier": "pong", "t": t, "server_time": round(server_time, 6)}


def backend_message(name: str, failure: str | None) -> BackendMessage:
    """Whether the backend works; sent to every client when that changes (and in ``hello``)."""
    message = None if failure is None else clip(failure)
    return {"identifier": "backend", "name": name, "ok": failure is None, "message": message}


def model_message(robot: str, url: str) -> ModelMessage:
    """A new glTF model for ``robot`` (built from its robot_description); replaces hello's ``model``."""
    return {"identifier": robot_identifier(robot, "model"), "url": url}


def scene_message(url: str | None, map_to_scene: Transform2D) -> SceneMessage:
    """A new twin for the clients to load (e.g. built from a live /map); same shape as ``hello.scene``."""
    return {"identifier": "scene", "url": url, "map_to_scene": map_to_scene}


def playback_message(*, position: float, duration: float, rate: float, paused: bool, loop: bool) -> PlaybackMessage:
    """Where a replayed recording is (bag backend), in seconds from its start."""
    return {
        "identifier": "playback",
        "position": round(position, 3),
        "duration": round(duration, 3),
        "rate": rate,
        "paused": paused,
        "loop": loop,
    }


def lease_message(robot: str, *, holder: str | None, previous: str | None, reason: LeaseReason) -> LeaseMessage:
    """Who controls ``robot`` now; sent to every client when that changes."""
    return {"identifier": robot_identifier(robot, "lease"), "holder": holder, "previous": previous, "reason": reason}


def estop_message(robots: list[str], client_id: str | None, *, latched: bool = True) -> EstopMessage:
    """Broadcast to every client when an emergency stop was carried out (``latched``) or reset (not)."""
    return {"identifier": "estop", "robots": robots, "by": client_id, "latched": latched}


def voxel_map_message(
    *, version: int, since: int, reset: bool, voxel: float, blocks: int, frames: int
) -> VoxelMapMessage:
    """What the binary frames after it carry of the voxel map (docs/protocol.md, "Voxel map blocks")."""
    return {"identifier": "voxel_map", "version": version, "since": since, "reset": reset, "voxel": voxel,
            "blocks": blocks, "frames": frames}  # fmt: skip
