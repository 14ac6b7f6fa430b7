"""What clients are told of inspection work: ``targets``, ``mission``, ``finding``, ``region``, ``alert`` and
``schedules`` (docs/protocol.md).

Missions, findings and targets go through every client's priority lane: they are few, and none may be coalesced
away (a finding is not a newer value of another). A client that connects gets the targets, the missions and the
latest findings right after ``hello``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, TypedDict

from ..wire.fields import RequestId
from .records import (
    AlertRecord,
    AlertSeverity,
    FindingRecord,
    FindingStatus,
    MissionRecord,
    MissionState,
    ReadingTrend,
    ScheduleOutcome,
    ScheduleRecord,
    ScheduleRun,
    StepKind,
    Target,
)
from .schedule_rules import WEEKDAYS

#: Findings a newly connected client is sent (the newest); the rest are in the report and the database.
FINDINGS_ON_CONNECT = 200
#: Findings in a page of the history when ``findings/page`` names no limit.
FINDINGS_PAGE = 50
#: Missions a client gets after its ``hello``: every active one, and the newest of those that ended.
MISSIONS_ON_CONNECT = 100
#: Unacknowledged alerts a client gets after its ``hello`` (the newest), and the most the relay holds in memory.
ALERTS_ON_CONNECT = 500


class TargetDescription(TypedDict):
    id: str
    name: str
    kind: str
    x: float
    y: float
    facing: float | None


class TargetsMessage(TypedDict):
    identifier: Literal["targets"]
    targets: list[TargetDescription]


class TargetsChangedMessage(TypedDict):
    identifier: Literal["targets_changed"]
    added: list[TargetDescription]  # new, or replacing the target of the same id
    removed: list[str]


class StepDescription(TypedDict):
    kind: StepKind
    target: str | None
    x: float | None
    y: float | None
    yaw: float | None
    seconds: float | None


class MissionMessage(TypedDict):
    identifier: Literal["mission"]
    id: str
    name: str
    robot: str
    state: MissionState
    current: int
    steps: list[StepDescription]
    reason: str
    owner: str
    updated: float


class TrendDescription(TypedDict):
    """A reading over the target's last rounds (relay.inspection.trend): ``points`` are ``[time, value]`` (Unix s),
    oldest first; ``threshold`` the limit it is measured against (null: its sensor has none)."""

    sensor: str
    unit: str
    threshold: float | None
    points: list[list[float]]


class FindingMessage(TypedDict):
    identifier: Literal["finding"]
    id: str
    capture: str
    mission: str | None
    target: str | None
    robot: str
    x: float
    y: float
    status: FindingStatus
    note: str
    source: Literal["operator", "rule"]
    region: list[list[int]] | None
    image: str | None  # URL of the capture's JPEG (/captures/<sha256>.jpg), None: no image
    readings: dict[str, float]
    created: float
    updated: float
    change: float | None  # a change finding's score (the changed share of the view, 0-1); None for the others
    baseline: str | None  # the capture a change finding was compared with (its before image); None for the others
    before: str | None  # URL of the baseline's JPEG (/captures/<sha256>.jpg); None: no baseline, or it has no image
    trend: TrendDescription | None  # the reading the finding was judged on over the last rounds; None: no history


class FindingsMessage(TypedDict):
    """The answer to ``findings/page``: a page of the history, newest first; ``more``: older ones remain."""

    identifier: Literal["findings"]
    id: RequestId
    findings: list[FindingMessage]
    more: bool


class AlertAcknowledgement(TypedDict):
    by: str  # the operator's name (their client id when they gave none)
    at: float
    note: str


class AlertMessage(TypedDict):
    """An alert as raised, and again once acknowledged (``acknowledged`` set): clients drop it from their list."""

    identifier: Literal["alert"]
    alert: str
    kind: str
    robot: str | None
    subject: str | None
    text: str
    severity: AlertSeverity
    raised: float
    acknowledged: AlertAcknowledgement | None


class RegionMessage(TypedDict):
    identifier: Literal["region"]
    id: RequestId
    capture: str
    outline: list[list[int]]


def _target(t: Target) -> TargetDescription:
    return {"id": t.id, "name": t.name, "kind": t.kind, "x": t.x, "y": t.y, "facing": t.facing}


def targets_message(targets: list[Target]) -> TargetsMessage:
    """Every target: what a client gets after its ``hello``."""
    return {"identifier": "targets", "targets": [_target(t) for t in targets]}


def targets_changed_message(added: list[Target], removed: Sequence[str] = ()) -> TargetsChangedMessage:
    """What changed since: every client gets this, never the whole list again (it grew with every add)."""
    return {"identifier": "targets_changed", "added": [_target(t) for t in added], "removed": list(removed)}


def mission_message(record: MissionRecord) -> MissionMessage:
    return {
        "identifier": "mission",
        "id": record.id,
        "name": record.name,
        "robot": record.robot,
        "state": record.state,
        "current": record.current,
        "steps": [
            {"kind": s.kind, "target": s.target, "x": s.x, "y": s.y, "yaw": s.yaw, "seconds": s.seconds}
            for s in record.steps
        ],
        "reason": record.reason,
        "owner": record.owner,
        "updated": round(record.updated, 3),
    }


def finding_message(
    finding: FindingRecord, image: str | None, readings: dict[str, float], before: str | None = None
) -> FindingMessage:
    """``image`` and ``before``: the SHA-256 of the capture's JPEG and of the baseline capture's, or None."""
    return {
        "identifier": "finding",
        "id": finding.id,
        "capture": finding.capture,
        "mission": finding.mission,
        "target": finding.target,
        "robot": finding.robot,
        "x": finding.x,
        "y": finding.y,
        "status": finding.status,
        "note": finding.note,
        "source": finding.source,
        "region": None if finding.region is None else [list(p) for p in finding.region],
        "image": None if image is None else f"/captures/{image}.jpg",
        "readings": readings,
        "created": round(finding.created, 3),
        "updated": round(finding.updated, 3),
        "change": finding.change,
        "baseline": finding.baseline,
        "before": None if before is None or finding.baseline is None else f"/captures/{before}.jpg",
        "trend": None if finding.trend is None else _trend(finding.trend),
    }


def _trend(trend: ReadingTrend) -> TrendDescription:
    return {
        "sensor": trend.sensor,
        "unit": trend.unit,
        "threshold": trend.threshold,
        "points": [[round(t, 3), value] for t, value in trend.points],
    }


def alert_message(alert: AlertRecord) -> AlertMessage:
    acknowledged: AlertAcknowledgement | None = None
    if alert.acked_by is not None:
        acknowledged = {"by": alert.acked_by, "at": round(alert.acked_at or 0.0, 3), "note": alert.ack_note}
    return {
        "identifier": "alert",
        "alert": alert.id,
        "kind": alert.kind,
        "robot": alert.robot,
        "subject": alert.subject,
        "text": alert.text,
        "severity": alert.severity,
        "raised": round(alert.raised, 3),
        "acknowledged": acknowledged,
    }


# -- schedules (relay.inspection.scheduler): every schedule with its next run, its last run and its state, sent
# after ``hello`` and to every client when any changes (they are few: at most scheduler.MAX_SCHEDULES) ----------------

ScheduleStateName = Literal["scheduled", "waiting", "running", "over"]


@dataclass(frozen=True, slots=True)
class ScheduleState:
    """A schedule as clients see it now (relay.inspection.scheduler.Scheduler.states)."""

    record: ScheduleRecord
    next_run: float | None
    last: ScheduleRun | None
    state: ScheduleStateName
    reason: str
    now: float


class WindowDescription(TypedDict):
    days: list[str]  # "mon" .. "sun"
    hours: list[int]  # [first, last): 8, 17 is 08:00 to 17:00


class BlackoutDescription(TypedDict):
    start: float
    end: float


class ScheduleRunDescription(TypedDict):
    slot: float
    t: float
    outcome: ScheduleOutcome
    mission: str | None
    reason: str


class ScheduleDescription(TypedDict):
    schedule: str
    mission: dict[str, Any]
    start: float
    repeat: float
    windows: list[WindowDescription]
    blackouts: list[BlackoutDescription]
    priority: int
    on_busy: Literal["wait", "skip"]
    owner: str
    updated: float
    next_run: float | None
    last_run: ScheduleRunDescription | None
    state: ScheduleStateName
    reason: str


class SchedulesMessage(TypedDict):
    identifier: Literal["schedules"]
    schedules: list[ScheduleDescription]


def schedule_description(found: ScheduleState) -> ScheduleDescription:
    record, last = found.record, found.last
    return {
        "schedule": record.id,
        "mission": record.mission,
        "start": record.start,
        "repeat": record.repeat,
        "windows": [
            {"days": [WEEKDAYS[d] for d in days], "hours": [first, end]} for days, first, end in record.windows
        ],
        "blackouts": [{"start": a, "end": b} for a, b in record.blackouts],
        "priority": record.priority,
        "on_busy": record.on_busy,
        "owner": record.owner,
        "updated": record.updated,
        "next_run": found.next_run,
        "last_run": None
        if last is None
        else {"slot": last.slot, "t": last.t, "outcome": last.outcome, "mission": last.mission, "reason": last.reason},
        "state": found.state,
        "reason": found.reason,
    }


def schedules_message(states: Sequence[ScheduleState]) -> SchedulesMessage:
    return {"identifier": "schedules", "schedules": [schedule_description(s) for s in states]}


#: Every message of the inspection feature (relay/station/messages.py gathers it into ``ServerMessage``).
InspectionMessage = (
    TargetsMessage
    | TargetsChangedMessage
    | MissionMessage
    | FindingMessage
    | RegionMessage
    | FindingsMessage
    | AlertMessage
    | SchedulesMessage
)


def findings_message(request_id: RequestId, findings: list[FindingMessage], more: bool) -> FindingsMessage:
    return {"identifier": "findings", "id": request_id, "findings": findings, "more": more}


def region_message(request_id: RequestId, capture: str, outline: tuple[tuple[int, int], ...]) -> RegionMessage:
    return {"identifier": "region", "id": request_id, "capture": capture, "outline": [list(p) for p in outline]}
