"""The inspection commands on the wire: missions, findings, regions and targets (docs/protocol.md).

Parsed like every other command (relay.protocol, whose helpers this uses): a bad frame gets one ``error`` naming
the field; nothing here touches a robot. Every command is global (``mission/start``, not ``robot1/...``): a
mission may span the fleet, and findings belong to captures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final, Literal, NotRequired, TypedDict

from ..errors import ProtocolError
from ..fields import MAX_COORDINATE, MAX_YAW, ErrorCode, RequestId
from ..fields import number as _number
from ..fields import request_id as _request_id
from ..fields import show as _show
from ..fields import string as _string
from .records import FINDING_STATUSES, FindingStatus

MISSION_ACTIONS: Final = ("pause", "resume", "skip", "abort")
INSPECTION_KINDS: Final = (
    "mission/start",
    *(f"mission/{a}" for a in MISSION_ACTIONS),
    "finding/mark",
    "finding/update",
    "region",
    "target/add",
)
#: Longest note a finding keeps; points of a region outline.
MAX_NOTE = 1000
MAX_OUTLINE = 256
MAX_PIXEL = 16384


@dataclass(frozen=True, slots=True)
class MissionStart:
    id: RequestId
    file: str | None  # a mission file of the relay's missions directory, by name ("demo")
    robot: str | None  # with steps
    steps: Any  # checked by relay.inspection.missions.steps_from_wire
    targets: tuple[str, ...] | None  # for the fleet
    name: str | None


@dataclass(frozen=True, slots=True)
class MissionControl:
    id: RequestId
    action: Literal["pause", "resume", "skip", "abort"]
    mission: str


@dataclass(frozen=True, slots=True)
class FindingMark:
    """``finding/mark`` (a new finding about ``capture``) or ``finding/update`` (of ``finding``)."""

    id: RequestId
    action: Literal["mark", "update"]
    capture: str | None
    finding: str | None
    status: FindingStatus | None
    note: str | None
    region: tuple[tuple[int, int], ...] | None


@dataclass(frozen=True, slots=True)
class RegionRequest:
    """Segment the region of ``capture``'s image around pixel (u, v) (GrabCut); the outline comes back."""

    id: RequestId
    capture: str
    u: int
    v: int


@dataclass(frozen=True, slots=True)
class TargetAdd:
    """A target at (x, y), or where pixel (u, v) of ``capture``'s image looks (relay.inspection.pixel), or where pixel
    (u, v) of ``robot``'s live camera looks (a capture taken now, and a finding about it to review)."""

    id: RequestId
    target: str
    x: float | None
    y: float | None
    name: str | None
    kind: str | None
    facing: float | None
    capture: str | None = None
    u: float | None = None
    v: float | None = None
    robot: str | None = None


InspectionCommand = MissionStart | MissionControl | FindingMark | RegionRequest | TargetAdd


class MissionFileCommand(TypedDict):
    identifier: Literal["mission/start"]
    id: RequestId
    file: str


class MissionStepsCommand(TypedDict):
    identifier: Literal["mission/start"]
    id: RequestId
    robot: str
    steps: list[dict[str, Any]]
    name: NotRequired[str]


class MissionTargetsCommand(TypedDict):
    identifier: Literal["mission/start"]
    id: RequestId
    targets: list[str]
    name: NotRequired[str]


class MissionControlCommand(TypedDict):
    identifier: Literal["mission/pause", "mission/resume", "mission/skip", "mission/abort"]
    id: RequestId
    mission: str


class FindingMarkCommand(TypedDict):
    identifier: Literal["finding/mark"]
    id: RequestId
    capture: str
    status: FindingStatus
    note: NotRequired[str]
    region: NotRequired[list[list[int]]]


class FindingUpdateCommand(TypedDict):
    identifier: Literal["finding/update"]
    id: RequestId
    finding: str
    status: NotRequired[FindingStatus]
    note: NotRequired[str]
    region: NotRequired[list[list[int]] | None]


class RegionCommand(TypedDict):
    identifier: Literal["region"]
    id: RequestId
    capture: str
    u: float
    v: float


class TargetAddCommand(TypedDict):
    identifier: Literal["target/add"]
    id: RequestId
    target: str
    x: float
    y: float
    name: NotRequired[str]
    kind: NotRequired[str]
    facing: NotRequired[float]


class TargetFromPixelCommand(TypedDict):
    identifier: Literal["target/add"]
    id: RequestId
    target: str
    capture: str
    u: float
    v: float
    name: NotRequired[str]
    kind: NotRequired[str]


class TargetFromLiveCommand(TypedDict):
    identifier: Literal["target/add"]
    id: RequestId
    target: str
    robot: str
    u: float
    v: float
    name: NotRequired[str]
    kind: NotRequired[str]


def inspection_identifier(command: InspectionCommand) -> str:
    if isinstance(command, MissionStart):
        return "mission/start"
    if isinstance(command, MissionControl):
        return f"mission/{command.action}"
    if isinstance(command, FindingMark):
        return f"finding/{command.action}"
    return "region" if isinstance(command, RegionRequest) else "target/add"


def parse_inspection(obj: dict[str, Any], identifier: str) -> InspectionCommand:
    rid = _request_id(obj, required=True)
    assert rid is not None
    try:
        return _parse(obj, identifier, rid)
    except ProtocolError as exc:
        exc.request_id = rid
        raise


def _parse(obj: dict[str, Any], identifier: str, rid: RequestId) -> InspectionCommand:
    if identifier == "mission/start":
        file = _string(obj, "file", identifier, required=False)
        robot = _string(obj, "robot", identifier, required=False)
        steps = obj.get("steps")
        targets = _strings(obj, "targets", identifier)
        given = [k for k in ("file", "steps", "targets") if obj.get(k) is not None]
        if len(given) != 1:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: give exactly one of file, steps, targets")
        if (steps is None) != (robot is None):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: steps need a robot, and a robot needs steps")
        return MissionStart(rid, file, robot, steps, targets, _string(obj, "name", identifier, required=False))
    if identifier.startswith("mission/"):
        mission = _string(obj, "mission", identifier, required=True)
        assert mission is not None
        return MissionControl(rid, identifier.partition("/")[2], mission)  # type: ignore[arg-type]
    if identifier in ("finding/mark", "finding/update"):
        action = identifier.partition("/")[2]
        status = obj.get("status")
        if status is not None and status not in FINDING_STATUSES:
            raise ProtocolError(
                ErrorCode.BAD_REQUEST,
                f"{identifier}: field 'status' must be one of {', '.join(FINDING_STATUSES)}, got {_show(status)}",
            )
        if action == "mark" and status is None:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: missing field 'status'")
        note = _note(obj.get("note"), identifier)
        return FindingMark(
            rid,
            action,  # type: ignore[arg-type]
            _string(obj, "capture", identifier, required=action == "mark"),
            _string(obj, "finding", identifier, required=action == "update"),
            status,
            note,
            _outline(obj.get("region"), identifier),
        )
    if identifier == "region":
        capture = _string(obj, "capture", identifier, required=True)
        u = _number(obj, "u", identifier, low=0, high=MAX_PIXEL)
        v = _number(obj, "v", identifier, low=0, high=MAX_PIXEL)
        assert capture is not None and u is not None and v is not None
        return RegionRequest(rid, capture, int(u), int(v))
    # target/add
    target = _string(obj, "target", identifier, required=True)
    assert target is not None
    from .targets import TARGET_ID

    if not TARGET_ID.match(target):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: field 'target' must be 1-64 letters, digits, _ or -")
    name = _string(obj, "name", identifier, required=False)
    kind = _string(obj, "kind", identifier, required=False)
    if obj.get("capture") is not None:
        capture = _string(obj, "capture", identifier, required=True)
        u = _number(obj, "u", identifier, low=0, high=MAX_PIXEL)
        v = _number(obj, "v", identifier, low=0, high=MAX_PIXEL)
        return TargetAdd(rid, target, None, None, name, kind, None, capture, u, v)
    if obj.get("robot") is not None:
        robot = _string(obj, "robot", identifier, required=True)
        u = _number(obj, "u", identifier, low=0, high=MAX_PIXEL)
        v = _number(obj, "v", identifier, low=0, high=MAX_PIXEL)
        return TargetAdd(rid, target, None, None, name, kind, None, None, u, v, robot)
    if obj.get("x") is None or obj.get("y") is None:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{identifier}: give x and y, a capture with u and v, or a robot with u and v"
        )
    x = _number(obj, "x", identifier, low=-MAX_COORDINATE, high=MAX_COORDINATE)
    y = _number(obj, "y", identifier, low=-MAX_COORDINATE, high=MAX_COORDINATE)
    facing = _number(obj, "facing", identifier, required=False, low=-MAX_YAW, high=MAX_YAW)
    return TargetAdd(rid, target, x, y, name, kind, facing)


def _strings(obj: dict[str, Any], field: str, identifier: str) -> tuple[str, ...] | None:
    value = obj.get(field)
    if value is None:
        return None
    if not isinstance(value, list) or not 1 <= len(value) <= 200 or not all(isinstance(v, str) for v in value):
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: field '{field}' must be a list of 1 to 200 names")
    return tuple(value)


def _outline(value: Any, identifier: str) -> tuple[tuple[int, int], ...] | None:
    if value is None:
        return None
    ok = isinstance(value, list) and 3 <= len(value) <= MAX_OUTLINE
    points: list[tuple[int, int]] = []
    for point in value if ok else ():
        if not (
            isinstance(point, list)
            and len(point) == 2
            and all(isinstance(c, int | float) and not isinstance(c, bool) and math.isfinite(c) for c in point)
            and all(0 <= c <= MAX_PIXEL for c in point)
        ):
            ok = False
            break
        points.append((int(point[0]), int(point[1])))
    if not ok:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field 'region' must be a list of 3 to {MAX_OUTLINE} [u, v] pixels",
        )
    return tuple(points)


def _note(value: Any, identifier: str) -> str | None:
    """A finding's note: up to MAX_NOTE characters, and ``""`` clears it (the generic string field is 1 to 64
    characters, which cut notes at 64 where docs/protocol.md promises 1000 and left no way to clear one)."""
    if value is None:
        return None
    if not isinstance(value, str) or len(value) > MAX_NOTE:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field 'note' must be a string of at most {MAX_NOTE} characters (\"\" clears it), "
            f"got {_show(value)}",
        )
    return value
