"""The fields every client command is read from, and the codes a refusal carries: the bottom of the wire layer.

``relay.session.protocol`` parses the station's own commands with these and ``relay.inspection.wire`` the inspection
commands; both import this module, neither the other's internals. It imports nothing of the relay but its errors.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Final

import orjson

from ..errors import ProtocolError

#: Longest accepted ``id`` string: ids are echoed back, so they must stay small.
MAX_ID_LENGTH: Final = 128
#: Largest coordinate of a goal when no map bounds it (m): beyond any facility, below float trouble.
MAX_COORDINATE: Final = 1.0e6
#: Largest goal yaw (rad) accepted; yaws wrap, so this only catches nonsense.
MAX_YAW: Final = 100.0

RequestId = str | int


class ErrorCode:
    """The ``code`` values of ``error`` messages: short words a program can switch on."""

    BAD_REQUEST: Final = "bad_request"  # not JSON, not an object, missing or ill-typed field
    UNKNOWN_IDENTIFIER: Final = "unknown_identifier"  # no such message kind
    UNKNOWN_ROBOT: Final = "unknown_robot"
    OUT_OF_BOUNDS: Final = "out_of_bounds"  # goal outside the known map
    NO_PATH: Final = "no_path"  # goal inside an obstacle or unreachable
    NO_CAMERA: Final = "no_camera"  # the robot has no such camera, or no frame to give
    FORBIDDEN: Final = "forbidden"  # the client's role may not do this
    TOO_LARGE: Final = "too_large"  # frame over MAX_TEXT_BYTES
    UNSUPPORTED: Final = "unsupported"  # e.g. a binary frame from a client (none is defined)
    INTERNAL: Final = "internal"  # the relay failed; the message says what to report
    RECORDING: Final = "recording"  # the robot is a recording (bag backend): it cannot be commanded
    LEASED: Final = "leased"  # another operator controls the robot
    RATE_LIMITED: Final = "rate_limited"  # the client sends faster than the relay accepts
    ESTOPPED: Final = "estopped"  # the robot's emergency stop is latched: reset it before moving it
    SUPERSEDED: Final = "superseded"  # an estop, take-over, cancel or newer goal overtook this command
    AUDIT_UNAVAILABLE: Final = "audit_unavailable"  # the relay cannot record commands: it moves no robot
    STALE: Final = "stale"  # a motion command older than the deadman timeout when the relay got to it: dropped
    BUSY: Final = "busy"  # the snapshot budget or a work pool (planning, rendering) is full: try again shortly
    OCCUPIED: Final = "occupied"  # a goal on or next to another robot (safety.GOAL_CLEARANCE)
    UNREACHABLE: Final = "unreachable"  # nothing on the robot's side subscribes to the command's topic
    NO_ARM: Final = "no_arm"  # an arm command for a robot without an arm (or whose arm's files are absent)
    ARM_REFUSED: Final = "arm_refused"  # the arm's rules refuse the motion (joint limit, workspace, self-collision)

    ALL: Final = (
        BAD_REQUEST,
        UNKNOWN_IDENTIFIER,
        UNKNOWN_ROBOT,
        OUT_OF_BOUNDS,
        NO_PATH,
        NO_CAMERA,
        FORBIDDEN,
        TOO_LARGE,
        UNSUPPORTED,
        INTERNAL,
        RECORDING,
        LEASED,
        RATE_LIMITED,
        ESTOPPED,
        SUPERSEDED,
        AUDIT_UNAVAILABLE,
        STALE,
        BUSY,
        OCCUPIED,
        UNREACHABLE,
        NO_ARM,
        ARM_REFUSED,
    )


#: A field that is absent (``obj.get(field, MISSING)``), told apart from one that is null.
MISSING: Final = object()


def request_id(obj: Mapping[str, Any], *, required: bool) -> RequestId | None:
    value = obj.get("id", MISSING)
    if value is MISSING or value is None:
        if required:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{obj.get('identifier')!s}: missing field 'id'")
        return None
    if isinstance(value, bool) or not isinstance(value, str | int):
        raise ProtocolError(ErrorCode.BAD_REQUEST, "field 'id' must be a string or an integer")
    if isinstance(value, str) and not 0 < len(value) <= MAX_ID_LENGTH:
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"field 'id' must be 1 to {MAX_ID_LENGTH} characters")
    if isinstance(value, int) and abs(value) > 2**53:
        # Larger integers do not survive a round trip through a JavaScript number.
        raise ProtocolError(ErrorCode.BAD_REQUEST, "field 'id' must be an integer within +-2**53")
    return value


def number(
    obj: Mapping[str, Any],
    field: str,
    identifier: str,
    *,
    required: bool = True,
    low: float = -math.inf,
    high: float = math.inf,
) -> float | None:
    value = obj.get(field, MISSING)
    if value is MISSING or (value is None and not required):
        if required:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: missing field '{field}'")
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: field '{field}' must be a number, got {show(value)}")
    number = float(value)
    if not math.isfinite(number):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: field '{field}' must be finite")
    if not low <= number <= high:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{identifier}: field '{field}' must be between {low:g} and {high:g}"
        )
    return number


def string(obj: Mapping[str, Any], field: str, identifier: str, *, required: bool) -> str | None:
    value = obj.get(field, MISSING)
    if value is MISSING or value is None:
        if required:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: missing field '{field}'")
        return None
    if not isinstance(value, str) or not 0 < len(value) <= 64:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field '{field}' must be a string of 1 to 64 characters, got {show(value)}",
        )
    return value


def show(value: object) -> str:
    """A short rendering of a bad value for an error message (never echoes a huge payload)."""
    text = orjson.dumps(value, default=repr).decode() if not isinstance(value, float) else repr(value)
    return text if len(text) <= 40 else text[:37] + "..."
