"""The wire form of each client command: what a browser sends, typed for the generated ``ClientMessage`` of
xr_client/src/protocol.js (tools/gen_protocol_js.py). The parser (relay.protocol) is the authority on what is
accepted; tests/test_schema.py checks each TypedDict here against it, field by field.
"""

from __future__ import annotations

from typing import Literal, NotRequired, TypeAlias, TypedDict

from .inspection.wire import (
    FindingMarkCommand,
    FindingUpdateCommand,
    MissionControlCommand,
    MissionFileCommand,
    MissionStepsCommand,
    MissionTargetsCommand,
    RegionCommand,
    TargetAddCommand,
    TargetFromLiveCommand,
    TargetFromPixelCommand,
)
from .protocol import RequestId


class GoalPoseCommand(TypedDict):
    identifier: str  # <robot>/goal_pose
    id: RequestId
    x: float
    y: float
    yaw: NotRequired[float | None]


class CmdVelCommand(TypedDict):
    identifier: str  # <robot>/cmd_vel
    linear: float
    angular: float
    id: NotRequired[RequestId]
    t: NotRequired[float]  # ms on the client's monotonic clock (performance.now()): how old the command is


class CancelCommand(TypedDict):
    identifier: str  # <robot>/cancel
    id: RequestId


class SnapshotCommand(TypedDict):
    identifier: str  # <robot>/snapshot
    id: RequestId
    camera: NotRequired[str]


class StreamCommand(TypedDict):
    identifier: str  # <robot>/stream
    id: RequestId
    camera: str
    fps: float
    codec: NotRequired[Literal["jpeg", "h264"]]  # jpeg when omitted; h264 when hello's camera codecs offer it


class LeaseCommand(TypedDict):
    identifier: str  # <robot>/lease
    id: RequestId
    action: NotRequired[Literal["acquire", "release"]]
    force: NotRequired[bool]


class EstopCommand(TypedDict):
    identifier: Literal["estop"]
    id: RequestId
    robot: NotRequired[str]
    action: NotRequired[Literal["stop", "reset"]]


class NameCommand(TypedDict):
    identifier: Literal["name"]
    id: RequestId
    name: str


class PingCommand(TypedDict):
    identifier: Literal["ping"]
    t: float


class PlaybackCommand(TypedDict):
    identifier: Literal["playback/pause", "playback/resume"]
    id: RequestId


class PlaybackSeekCommand(TypedDict):
    identifier: Literal["playback/seek"]
    id: RequestId
    t: float


class PlaybackRateCommand(TypedDict):
    identifier: Literal["playback/rate"]
    id: RequestId
    rate: float


ClientMessage: TypeAlias = (
    GoalPoseCommand
    | CmdVelCommand
    | CancelCommand
    | SnapshotCommand
    | StreamCommand
    | LeaseCommand
    | EstopCommand
    | PingCommand
    | NameCommand
    | PlaybackCommand
    | PlaybackSeekCommand
    | PlaybackRateCommand
    | MissionFileCommand
    | MissionStepsCommand
    | MissionTargetsCommand
    | MissionControlCommand
    | FindingMarkCommand
    | FindingUpdateCommand
    | RegionCommand
    | TargetAddCommand
    | TargetFromPixelCommand
    | TargetFromLiveCommand
)
