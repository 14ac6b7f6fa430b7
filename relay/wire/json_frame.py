"""A client's text frame as a bounded JSON object: size, nesting and string lengths checked before any field."""

from __future__ import annotations

from typing import Any, Final

import orjson

from ..errors import ProtocolError
from .fields import ErrorCode, RequestId, request_id

#: Largest text frame the relay parses; larger ones get ``too_large`` (the socket itself caps at 1 MiB).
MAX_TEXT_BYTES: Final = 64 * 1024
#: Deepest nesting of a client message (objects and arrays); v1 messages need 2.
MAX_JSON_DEPTH: Final = 8
#: Longest string anywhere in a client message.
MAX_STRING_LENGTH: Final = 1024


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


def peek_request_id(obj: object) -> RequestId | None:
    """Best-effort ``id`` of a message that failed validation, so its ``error`` can name it."""
    if not isinstance(obj, dict):
        return None
    try:
        return request_id(obj, required=False)
    except ProtocolError:
        return None
