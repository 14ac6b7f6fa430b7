"""Every server message: the station's (relay/wire/messages.py, with hello's descriptions and binary frames
beside it) and each feature's (relay/inspection/messages.py), gathered for the parts that send them and for the
browser's generated types."""

from __future__ import annotations

from ..inspection.messages import InspectionMessage
from ..wire.descriptions import *  # noqa: F403
from ..wire.frames import FrameHeader as FrameHeader
from ..wire.frames import decode_frame as decode_frame
from ..wire.frames import encode_frame as encode_frame
from ..wire.messages import *  # noqa: F403
from ..wire.messages import StationMessage

#: Every message the server sends as a text frame (the browser's ``ServerMessage`` is generated from this).
ServerMessage = StationMessage | InspectionMessage
