"""Every server message: the station's (relay/wire/messages.py, with hello's descriptions and binary frames
beside it) and each feature's (relay/inspection/messages.py, relay/arm/wire.py, relay/study/wire.py), gathered for
the parts that send them and for the browser's generated types."""

from __future__ import annotations

from ..arm.wire import JointsMessage
from ..inspection.messages import InspectionMessage
from ..sim.valve_wire import ValveMessage
from ..study.wire import StudyMessage
from ..wire.descriptions import *  # noqa: F403
from ..wire.frames import FrameHeader as FrameHeader
from ..wire.frames import decode_frame as decode_frame
from ..wire.frames import encode_frame as encode_frame
from ..wire.messages import *  # noqa: F403
from ..wire.messages import StationMessage
from ..wire.viewer import AvatarMessage as AvatarMessage
from ..wire.viewer import avatar_message as avatar_message

#: Every message the server sends as a text frame (the browser's ``ServerMessage`` is generated from this).
ServerMessage = StationMessage | InspectionMessage | JointsMessage | StudyMessage | AvatarMessage | ValveMessage
