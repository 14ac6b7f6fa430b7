"""Where the operators look from, on the wire (issue #34): the page's ``viewer`` (its head, and its hands or
controllers with their rays in VR, a few times a second) and the relay's ``avatar`` (a recorded operator's, in a
replay: relay/replay/). The relay checks a ``viewer`` and otherwise ignores it: the session's recording keeps it, as it
keeps every frame a client sends (relay/replay/recorder.py).

Map frame (REP 103), metres; a direction is a unit vector (``look``: where the head faces; ``ray``: where a hand's
controller points).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final, Literal, TypedDict

from ..errors import ProtocolError
from .declare import WireCommand, command, custom
from .fields import ErrorCode, show

#: A viewer further than this from the map's origin (m) is a mistake, not a place.
MAX_VIEWER_DISTANCE: Final = 10_000.0
#: Hands a viewer has at most, each named once.
HANDS: Final = ("left", "right")
#: How far a direction's length may be from 1 (rounding on the page).
UNIT_SLACK: Final = 0.01
#: What the operator looks through: the desktop's orbiting, top and following views, a robot's camera (Robot POV, on
#: the desktop or in a headset) and the headset's own view of the twin. A study counts the changes (relay/study/).
VIEWS: Final = ("orbit", "top", "follow", "pov", "free_roam")

Vec3 = tuple[float, float, float]
Hand = Literal["left", "right"]


class ViewerHead(TypedDict):
    position: list[float]
    look: list[float]


class ViewerHand(TypedDict):
    hand: Hand
    position: list[float]
    ray: list[float]


def _vector(value: Any, what: str, identifier: str, *, unit: bool) -> Vec3:
    ok = (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    )
    if ok and unit:
        ok = abs(math.hypot(*value) - 1.0) <= UNIT_SLACK
    elif ok:
        ok = all(abs(v) <= MAX_VIEWER_DISTANCE for v in value)
    if not ok:
        says = "a unit vector [x, y, z]" if unit else f"[x, y, z], three finite numbers within ±{MAX_VIEWER_DISTANCE:g}"
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: {what} must be {says}, got {show(value)}")
    return float(value[0]), float(value[1]), float(value[2])


def _object(value: Any, what: str, identifier: str, keys: Sequence[str]) -> Mapping[str, Any]:
    if not isinstance(value, dict) or sorted(value) != sorted(keys):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{identifier}: {what} must be an object of {', '.join(keys)}, got {show(value)}"
        )
    return value


def _head(value: Any, field: str, identifier: str) -> tuple[Vec3, Vec3]:
    if value is None:
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: missing field '{field}'")
    head = _object(value, field, identifier, ("position", "look"))
    return (
        _vector(head["position"], f"{field}.position", identifier, unit=False),
        _vector(head["look"], f"{field}.look", identifier, unit=True),
    )


def _hands(value: Any, field: str, identifier: str) -> tuple[tuple[Hand, Vec3, Vec3], ...]:
    if value is None:
        return ()
    if not isinstance(value, list) or len(value) > len(HANDS):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{identifier}: {field} must be a list of at most {len(HANDS)} hands"
        )
    hands: list[tuple[Hand, Vec3, Vec3]] = []
    for k, item in enumerate(value):
        where = f"{field}[{k}]"
        hand = _object(item, where, identifier, ("hand", "position", "ray"))
        side = hand["hand"]
        if side not in HANDS or any(side == h[0] for h in hands):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST, f"{identifier}: {where}.hand must be 'left' or 'right', each once"
            )
        position = _vector(hand["position"], f"{where}.position", identifier, unit=False)
        hands.append((side, position, _vector(hand["ray"], f"{where}.ray", identifier, unit=True)))
    return tuple(hands)


def _view(value: Any, field: str, identifier: str) -> str | None:
    if value is None:
        return None
    if value not in VIEWS:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{identifier}: {field} must be one of {', '.join(VIEWS)}, got {show(value)}"
        )
    return str(value)


@command("viewer")
@dataclass(frozen=True, slots=True)
class Viewer(WireCommand):
    """The page's viewpoint: its head and, in VR, its hands with their rays (map frame), and what it looks through
    (``view``, one of VIEWS; absent: not said). No reply."""

    head: tuple[Vec3, Vec3] = custom(_head, "ViewerHead", required=True)
    hands: tuple[tuple[Hand, Vec3, Vec3], ...] = custom(_hands, "ViewerHand[]", default=())
    view: str | None = custom(_view, " | ".join(f"'{v}'" for v in VIEWS))


#: The viewpoint's commands, gathered in relay/session/protocol.py.
VIEWER_COMMANDS: Final = (Viewer,)


class AvatarMessage(TypedDict):
    identifier: Literal["avatar"]
    client: str
    name: str | None
    stamp: float
    head: ViewerHead
    hands: list[ViewerHand]


def _listed(vector: Vec3, digits: int) -> list[float]:
    return [round(v, digits) for v in vector]


def avatar_message(
    client: str, name: str | None, stamp: float, head: tuple[Vec3, Vec3], hands: Sequence[tuple[Hand, Vec3, Vec3]]
) -> AvatarMessage:
    """A recorded operator's viewpoint at ``stamp`` (the time the relay got it): positions to the millimetre,
    directions to 1e-4."""
    return {
        "identifier": "avatar",
        "client": client,
        "name": name,
        "stamp": stamp,
        "head": {"position": _listed(head[0], 3), "look": _listed(head[1], 4)},
        "hands": [
            {"hand": side, "position": _listed(position, 3), "ray": _listed(ray, 4)} for side, position, ray in hands
        ],
    }
