"""Binary frames: a 4-byte big-endian header length, the header as UTF-8 JSON, then the payload (an image)."""

from __future__ import annotations

import struct
from typing import Any, Final, NotRequired, TypedDict

import orjson

from ..errors import ProtocolError
from .descriptions import Lens
from .fields import ErrorCode, RequestId

#: Binary frame header length prefix: 4 bytes, big-endian unsigned.
FRAME_PREFIX: Final = struct.Struct(">I")


class FrameHeader(TypedDict):
    identifier: str
    seq: int
    stamp: float
    encoding: str  # "jpeg" (a picture) or "h264" (an Annex B packet of the camera's video)
    width: int
    height: int
    lens: Lens
    request_id: RequestId | None
    keyframe: NotRequired[bool]  # h264: a decoder may start here
    codec: NotRequired[str]  # h264: the WebCodecs codec string, e.g. "avc1.42C01F"


def encode_frame(header: FrameHeader, payload: bytes) -> bytes:
    """``>I`` header length, UTF-8 JSON header, then the encoded image."""
    head = orjson.dumps(header)
    return FRAME_PREFIX.pack(len(head)) + head + payload


def decode_frame(data: bytes) -> tuple[dict[str, Any], bytes]:
    """Split a binary frame into its header object and payload (used by tools, tests and clients)."""
    if len(data) < FRAME_PREFIX.size:
        raise ProtocolError(ErrorCode.BAD_REQUEST, "binary frame shorter than its 4-byte header length")
    (length,) = FRAME_PREFIX.unpack_from(data)
    end = FRAME_PREFIX.size + length
    if end > len(data):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"binary frame header length {length} exceeds the frame")
    header = orjson.loads(data[FRAME_PREFIX.size : end])
    if not isinstance(header, dict):
        raise ProtocolError(ErrorCode.BAD_REQUEST, "binary frame header is not a JSON object")
    return header, data[end:]
