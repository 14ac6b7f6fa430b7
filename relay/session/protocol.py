"""Wire protocol v1 as the station speaks it: every client command it accepts, in one table, and the pacing of
camera streams. The typed form of docs/protocol.md is the wire layer (relay/wire/: fields, declared commands,
server messages, binary frames); this module gathers the station's commands and each feature's into the table
the session parses with, and names what the rest of the relay uses of the wire.

Text frames are JSON objects with a mandatory string ``identifier``; robot-scoped identifiers are
``<robot>/<kind>``. Binary frames carry camera images: a 4-byte big-endian header length, the header as
UTF-8 JSON, then the encoded image. The browser's constants, types and identifier helpers are generated from the
wire layer into ``xr_client/src/protocol.js`` (``tools/gen_protocol_js.py``).
"""

from __future__ import annotations

import math
from collections.abc import Collection
from typing import Final, TypeAlias

from ..arm.wire import ARM_COMMANDS, ArmCommand
from ..inspection.wire import INSPECTION_COMMANDS, InspectionCommand
from ..study.wire import STUDY_COMMANDS, StudyCommand
from ..wire.commands import MAX_CLIENT_CLOCK as MAX_CLIENT_CLOCK
from ..wire.commands import MAX_NAME_LENGTH as MAX_NAME_LENGTH
from ..wire.commands import MAX_PLAYBACK_RATE as MAX_PLAYBACK_RATE
from ..wire.commands import MAX_STREAM_FPS as MAX_STREAM_FPS
from ..wire.commands import MIN_PLAYBACK_RATE as MIN_PLAYBACK_RATE
from ..wire.commands import NAME_PATTERN as NAME_PATTERN
from ..wire.commands import STATION_COMMANDS, StationCommand
from ..wire.commands import STREAM_CODECS as STREAM_CODECS
from ..wire.fields import MAX_COORDINATE as MAX_COORDINATE
from ..wire.fields import MAX_ID_LENGTH as MAX_ID_LENGTH
from ..wire.fields import MAX_YAW as MAX_YAW
from ..wire.fields import ErrorCode as ErrorCode
from ..wire.fields import RequestId as RequestId
from ..wire.frames import FRAME_PREFIX as FRAME_PREFIX
from ..wire.identifiers import ROBOT_NAME_PATTERN as ROBOT_NAME_PATTERN
from ..wire.identifiers import SERVER_GLOBAL_KINDS as SERVER_GLOBAL_KINDS
from ..wire.identifiers import SERVER_ROBOT_KINDS as SERVER_ROBOT_KINDS
from ..wire.identifiers import camera_identifier as camera_identifier
from ..wire.identifiers import robot_identifier as robot_identifier
from ..wire.identifiers import sensor_key as sensor_key
from ..wire.identifiers import split_camera_identifier as split_camera_identifier
from ..wire.json_frame import MAX_JSON_DEPTH as MAX_JSON_DEPTH
from ..wire.json_frame import MAX_STRING_LENGTH as MAX_STRING_LENGTH
from ..wire.json_frame import MAX_TEXT_BYTES as MAX_TEXT_BYTES
from ..wire.json_frame import decode_json as decode_json
from ..wire.json_frame import peek_request_id as peek_request_id
from ..wire.messages import Mode as Mode
from ..wire.messages import Role as Role
from ..wire.table import CommandTable
from ..wire.viewer import VIEWER_COMMANDS, Viewer

PROTOCOL_VERSION: Final = 1

#: Every command a client may send: the station's own and each feature's. A new command is declared once (a
#: dataclass with its fields' wire rules, relay/wire/declare.py) and listed here or in its feature's list.
COMMANDS: Final = CommandTable(
    (*STATION_COMMANDS, *VIEWER_COMMANDS, *INSPECTION_COMMANDS, *ARM_COMMANDS, *STUDY_COMMANDS)
)
#: Robot-scoped kinds a client may send (``<robot>/<kind>``), and global identifiers a client may send.
CLIENT_ROBOT_KINDS: Final = COMMANDS.robot_kinds
CLIENT_GLOBAL_KINDS: Final = COMMANDS.global_kinds

#: A stream at ``fps`` takes a frame up to ``FRAME_SLACK`` of a period before the frame is due (:func:`take_frame`):
#: a 30 fps source whose frames come up to 8 ms early or late keeps all of them against a 30 fps request, and a
#: 60 fps one gives every other frame, evenly. The rule it replaces ("0.9 of a period since the last frame
#: taken") dropped each frame that came 4 ms early, and the relay delivered 22-27 of 30 fps
#: (bench/bench_camera.py, 2026-11-22); backends and the hub use this one.
FRAME_SLACK: Final = 0.5
#: Periods a stream that fell behind may catch up on (a burst of up to about this many frames more).
FRAME_CREDIT: Final = 2.0
#: At most this many ranges per ``<robot>/scan`` message, and at most this many messages per second.
MAX_SCAN_POINTS: Final = 360
MAX_SCAN_RATE: Final = 10.0

#: The inspection feature's commands: the session hands them to relay.inspection.
InspectionCommands: Final = INSPECTION_COMMANDS
#: The arm's commands: the session hands them to relay.control.arm_control.
ArmCommands: Final = ARM_COMMANDS
#: A study's commands: the session hands them to relay.study.service.
StudyCommands: Final = STUDY_COMMANDS
Command: TypeAlias = StationCommand | Viewer | InspectionCommand | ArmCommand | StudyCommand


def parse_command(data: str | bytes, robots: Collection[str]) -> Command:
    """Validate one client text frame and return its command (:meth:`CommandTable.parse` of :data:`COMMANDS`)."""
    return COMMANDS.parse(data, robots)  # type: ignore[return-value]


def command_identifier(command: Command) -> str:
    """The identifier a command arrived with."""
    return command.identifier


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
