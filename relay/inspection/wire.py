"""The inspection commands on the wire: missions, findings, regions, targets and alerts (docs/protocol.md).

Parsed like every other command (relay.session.protocol, whose helpers this uses): a bad frame gets one ``error`` naming
the field; nothing here touches a robot. Every command is global (``mission/start``, not ``robot1/...``): a
mission may span the fleet, and findings belong to captures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Final, Literal

from ..errors import ProtocolError
from ..wire.declare import Forms, Frame, WireCommand, command, custom, from_identifier, real, request, text
from ..wire.fields import MAX_COORDINATE, MAX_YAW, ErrorCode, RequestId, show
from .records import FINDING_STATUSES, TARGET_ID, FindingStatus

MISSION_ACTIONS: Final = ("pause", "resume", "skip", "abort")
#: Longest note a finding keeps; points of a region outline.
MAX_NOTE = 1000
MAX_OUTLINE = 256
MAX_PIXEL = 16384
#: Most findings one ``findings/page`` returns, and the latest time it may name (the year 2286).
MAX_PAGE = 100
MAX_TIME = 1.0e10
#: Longest note an alert's acknowledgement keeps.
MAX_ACK_NOTE = 200


@command("mission/start")
@dataclass(frozen=True, slots=True)
class MissionStart(WireCommand):
    """A mission from a file of the relay's missions directory (by name, "demo"), from steps for one robot, or
    from targets for the fleet or a group of it (``robots``: a team's or a room's, as the page groups them)."""

    FORMS: ClassVar[Forms] = {
        "MissionFileCommand": (("mission/start",), ("file",), ()),
        "MissionStepsCommand": (("mission/start",), ("robot", "steps"), ("name",)),
        "MissionTargetsCommand": (("mission/start",), ("targets",), ("name", "robots")),
    }
    id: RequestId = request()
    file: str | None = text(required=False)
    robot: str | None = text(required=False)
    steps: Any = custom(lambda value, _, __: value, "Object<string, unknown>[]")  # checked by missions.steps_from_wire
    targets: tuple[str, ...] | None = custom(lambda value, field, ident: _strings(value, field, ident), "string[]")
    name: str | None = text(required=False)
    robots: tuple[str, ...] | None = custom(lambda value, field, ident: _strings(value, field, ident), "string[]")

    def check(self, frame: Frame) -> None:
        if sum(given is not None for given in (self.file, self.steps, self.targets)) != 1:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: give exactly one of file, steps, targets")
        if (self.steps is None) != (self.robot is None):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST, f"{frame.identifier}: steps need a robot, and a robot needs steps"
            )
        if self.robots is not None:
            if self.targets is None:
                raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: robots (a group) go with targets")
            unknown = [r for r in self.robots if r not in frame.robots]
            if unknown:
                raise ProtocolError(
                    ErrorCode.UNKNOWN_ROBOT,
                    f"{frame.identifier}: unknown robot(s) {', '.join(r[:64] for r in unknown[:5])}",
                )


@command(*(f"mission/{action}" for action in MISSION_ACTIONS))
@dataclass(frozen=True, slots=True)
class MissionControl(WireCommand):
    id: RequestId = request()
    action: Literal["pause", "resume", "skip", "abort"] = from_identifier()
    mission: str = text()


@command("finding/mark", "finding/update")
@dataclass(frozen=True, slots=True)
class FindingMark(WireCommand):
    """``finding/mark`` (a new finding about ``capture``) or ``finding/update`` (of ``finding``)."""

    FORMS: ClassVar[Forms] = {
        "FindingMarkCommand": (("finding/mark",), ("capture", "status"), ("note", "region")),
        "FindingUpdateCommand": (("finding/update",), ("finding",), ("status", "note", "region")),
    }
    id: RequestId = request()
    action: Literal["mark", "update"] = from_identifier()
    capture: str | None = text(required=False)
    finding: str | None = text(required=False)
    status: FindingStatus | None = custom(lambda value, field, ident: _status(value, field, ident), "FindingStatus")
    note: str | None = custom(lambda value, _, ident: _note(value, ident, MAX_NOTE), "string")
    region: tuple[tuple[int, int], ...] | None = custom(
        lambda value, _, ident: _outline(value, ident), "number[][] | null"
    )

    def check(self, frame: Frame) -> None:
        needed = ("capture", "status") if self.action == "mark" else ("finding",)
        for field in needed:
            if getattr(self, field) is None:
                raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: missing field '{field}'")


@command("region")
@dataclass(frozen=True, slots=True)
class RegionRequest(WireCommand):
    """Segment the region of ``capture``'s image around pixel (u, v) (GrabCut); the outline comes back."""

    id: RequestId = request()
    capture: str = text()
    u: int = real(low=0, high=MAX_PIXEL, integer=True)
    v: int = real(low=0, high=MAX_PIXEL, integer=True)


@command("target/add")
@dataclass(frozen=True, slots=True)
class TargetAdd(WireCommand):
    """A target at (x, y), or where pixel (u, v) of ``capture``'s image looks (relay.inspection.pixel), or where pixel
    (u, v) of ``robot``'s live camera looks (a capture taken now, and a finding about it to review)."""

    FORMS: ClassVar[Forms] = {
        "TargetAddCommand": (("target/add",), ("target", "x", "y"), ("name", "kind", "facing")),
        "TargetFromPixelCommand": (("target/add",), ("target", "capture", "u", "v"), ("name", "kind")),
        "TargetFromLiveCommand": (("target/add",), ("target", "robot", "u", "v"), ("name", "kind")),
    }
    id: RequestId = request()
    target: str = text(pattern=TARGET_ID, says="1-64 letters, digits, _ or -")
    x: float | None = real(required=False, low=-MAX_COORDINATE, high=MAX_COORDINATE)
    y: float | None = real(required=False, low=-MAX_COORDINATE, high=MAX_COORDINATE)
    name: str | None = text(required=False)
    kind: str | None = text(required=False)
    facing: float | None = real(required=False, low=-MAX_YAW, high=MAX_YAW)
    capture: str | None = text(required=False)
    u: float | None = real(required=False, low=0, high=MAX_PIXEL)
    v: float | None = real(required=False, low=0, high=MAX_PIXEL)
    robot: str | None = text(required=False)

    def check(self, frame: Frame) -> None:
        source = self.capture or self.robot
        if source is not None and (self.u is None or self.v is None):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST, f"{frame.identifier}: missing field '{'u' if self.u is None else 'v'}'"
            )
        if source is None and (self.x is None or self.y is None):
            raise ProtocolError(
                ErrorCode.BAD_REQUEST,
                f"{frame.identifier}: give x and y, a capture with u and v, or a robot with u and v",
            )


@command("findings/page")
@dataclass(frozen=True, slots=True)
class FindingsPage(WireCommand):
    """A page of the findings history, newest first: at most ``limit`` findings made before ``before`` (seconds
    since the epoch, a finding's ``created``; none: the newest). Viewers may read it too."""

    id: RequestId = request()
    before: float | None = real(required=False, low=0.0, high=MAX_TIME)
    limit: int | None = real(required=False, low=1, high=MAX_PAGE, integer=True)


@command("alert/ack")
@dataclass(frozen=True, slots=True)
class AlertAck(WireCommand):
    """Acknowledge ``alert`` (an ``alert`` message's id), with an optional note: recorded with the operator's name,
    and every client learns it."""

    id: RequestId = request()
    alert: str = text()
    note: str | None = custom(lambda value, _, ident: _note(value, ident, MAX_ACK_NOTE), "string")


@command("schedule/add", "schedule/update")
@dataclass(frozen=True, slots=True)
class ScheduleChange(WireCommand):
    """A schedule made (``schedule/add``: a new name) or changed (``schedule/update``: the fields given replace the
    schedule's). Its rules (a window, a repeat of at least 60 s, targets that exist) are checked by
    relay.inspection.schedule_commands, against the schedule as it would be."""

    FORMS: ClassVar[Forms] = {
        "ScheduleAddCommand": (
            ("schedule/add",), ("schedule", "mission", "start", "repeat", "windows"),
            ("blackouts", "priority", "on_busy"),
        ),
        "ScheduleUpdateCommand": (
            ("schedule/update",), ("schedule",),
            ("mission", "start", "repeat", "windows", "blackouts", "priority", "on_busy"),
        ),
    }  # fmt: skip
    id: RequestId = request()
    action: Literal["add", "update"] = from_identifier()
    schedule: str = text(pattern=TARGET_ID, says="1-64 letters, digits, _ or -")
    mission: dict[str, Any] | None = custom(lambda value, _, ident: _mission(value, ident), "Object<string, unknown>")
    start: float | None = real(required=False, low=0.0, high=MAX_TIME)
    repeat: float | None = real(required=False, low=0.0, high=MAX_TIME)
    windows: tuple[tuple[tuple[int, ...], int, int], ...] | None = custom(
        lambda value, _, ident: _windows(value, ident), "{days: string[], hours: number[]}[]"
    )
    blackouts: tuple[tuple[float, float], ...] | None = custom(
        lambda value, _, ident: _blackouts(value, ident), "{start: number, end: number}[]"
    )
    priority: int | None = real(required=False, low=-1000, high=1000, integer=True)
    on_busy: Literal["wait", "skip"] | None = custom(lambda value, _, ident: _on_busy(value, ident), "'wait' | 'skip'")

    def check(self, frame: Frame) -> None:
        if self.action == "add":
            for field in ("mission", "start", "repeat", "windows"):
                if getattr(self, field) is None:
                    raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: missing field '{field}'")


@command("schedule/remove")
@dataclass(frozen=True, slots=True)
class ScheduleRemove(WireCommand):
    id: RequestId = request()
    schedule: str = text()


#: The inspection commands, for the station's table (relay/session/protocol.py).
INSPECTION_COMMANDS: Final = (
    MissionStart, MissionControl, FindingMark, RegionRequest, TargetAdd, FindingsPage, AlertAck, ScheduleChange,
    ScheduleRemove,
)  # fmt: skip
InspectionCommand = (
    MissionStart | MissionControl | FindingMark | RegionRequest | TargetAdd | FindingsPage | AlertAck | ScheduleChange
    | ScheduleRemove
)  # fmt: skip
#: The keys of a schedule's ``mission``: ``mission/start``'s (one of file, targets, robot with steps; a name).
MISSION_KEYS: Final = ("file", "targets", "robot", "steps", "name")
#: Most windows and blackouts a schedule keeps.
MAX_WINDOWS = 14
MAX_BLACKOUTS = 50


def _mission(value: Any, identifier: str) -> dict[str, Any] | None:
    if value is None:
        return None
    where = f"{identifier}: field 'mission'"
    if not isinstance(value, dict) or not value.keys() <= set(MISSION_KEYS):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{where} must be an object of {', '.join(MISSION_KEYS)} (as mission/start's)"
        )
    given = [k for k in ("file", "targets", "steps") if value.get(k) is not None]
    if len(given) != 1 or (value.get("steps") is None) != (value.get("robot") is None):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{where} must give exactly one of file, targets, or robot with steps"
        )
    for key in ("file", "robot", "name"):
        if key in value and not (isinstance(value[key], str) and 1 <= len(value[key]) <= 64):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{where}: '{key}' must be a string of 1 to 64 characters")
    if value.get("targets") is not None:
        _strings(value["targets"], "mission.targets", identifier)
    return dict(value)


def _windows(value: Any, identifier: str) -> tuple[tuple[tuple[int, ...], int, int], ...] | None:
    from .schedule_rules import ScheduleError, weekday_numbers

    if value is None:
        return None
    says = (
        f"{identifier}: field 'windows' must be a list of 1 to {MAX_WINDOWS} "
        '{"days": ["mon", ...], "hours": [first, last]} (hours 0 to 24)'
    )
    if not isinstance(value, list) or not 1 <= len(value) <= MAX_WINDOWS:
        raise ProtocolError(ErrorCode.BAD_REQUEST, says)
    windows = []
    for n, window in enumerate(value):
        days, hours = (window.get("days"), window.get("hours")) if isinstance(window, dict) else (None, None)
        if not (isinstance(days, list) and days and all(isinstance(d, str) for d in days)):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{says}; windows[{n}].days is not")
        if not (
            isinstance(hours, list)
            and len(hours) == 2
            and all(isinstance(h, int) and not isinstance(h, bool) and 0 <= h <= 24 for h in hours)
        ):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{says}; windows[{n}].hours is not")
        try:
            windows.append((weekday_numbers(days), hours[0], hours[1]))
        except ScheduleError as exc:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: windows[{n}]: {exc}") from None
    return tuple(windows)


def _blackouts(value: Any, identifier: str) -> tuple[tuple[float, float], ...] | None:
    if value is None:
        return None
    ok = isinstance(value, list) and len(value) <= MAX_BLACKOUTS
    found = []
    for item in value if ok else ():
        times = [item.get("start"), item.get("end")] if isinstance(item, dict) else [None]
        if not all(isinstance(t, int | float) and not isinstance(t, bool) and 0 <= t <= MAX_TIME for t in times):
            ok = False
            break
        found.append((float(times[0]), float(times[1])))  # type: ignore[arg-type]
    if not ok:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field 'blackouts' must be a list of at most {MAX_BLACKOUTS} "
            '{"start": s, "end": s} (seconds since the epoch)',
        )
    return tuple(found)


def _on_busy(value: Any, identifier: str) -> Literal["wait", "skip"] | None:
    if value is not None and value not in ("wait", "skip"):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST, f"{identifier}: field 'on_busy' must be 'wait' or 'skip', got {show(value)}"
        )
    return value  # type: ignore[no-any-return]


def _status(value: Any, field: str, identifier: str) -> FindingStatus | None:
    if value is not None and value not in FINDING_STATUSES:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field '{field}' must be one of {', '.join(FINDING_STATUSES)}, got {show(value)}",
        )
    return value  # type: ignore[no-any-return]


def _strings(value: Any, field: str, identifier: str) -> tuple[str, ...] | None:
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


def _note(value: Any, identifier: str, limit: int) -> str | None:
    """A note: up to ``limit`` characters (a finding's MAX_NOTE, an acknowledgement's MAX_ACK_NOTE), and ``""`` is
    none (the generic string field is 1 to 64 characters, which cut notes at 64 where docs/protocol.md promises 1000
    and left no way to clear one)."""
    if value is None:
        return None
    if not isinstance(value, str) or len(value) > limit:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field 'note' must be a string of at most {limit} characters (\"\" clears it), "
            f"got {show(value)}",
        )
    return value


def inspection_identifier(command: InspectionCommand) -> str:
    """The identifier an inspection command arrived with."""
    return command.identifier
