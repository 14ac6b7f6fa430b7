"""What inspection work leaves behind, as the store keeps it (relay.inspection.store) and the protocol sends it.

Plain frozen dataclasses; positions in the map frame (REP 103: metres, radians); times are Unix seconds.
"""

from __future__ import annotations

import re
import secrets
import time
from dataclasses import dataclass, field
from typing import Any, Final, Literal

#: What a target id may be: it names targets in mission files, KML placemarks and commands.
TARGET_ID: Final = re.compile(r"^[A-Za-z0-9_-]{1,64}$")

#: ``changed``: the place looks different from the target's previous round (relay.inspection.change_watch);
#: ``false_alarm``: an operator judged the finding not real (a shadow, a bucket moved), and says why in its note.
#: A status, not a flag beside one: the findings filter, pin colours, work orders, alerts and reports all key on it.
FindingStatus = Literal["ok", "anomaly", "needs_review", "changed", "false_alarm"]
FINDING_STATUSES: tuple[FindingStatus, ...] = ("ok", "anomaly", "needs_review", "changed", "false_alarm")
MissionState = Literal["pending", "running", "paused", "done", "aborted"]
StepKind = Literal["inspect", "goto", "capture", "dwell"]
AlertSeverity = Literal["warning", "critical"]
ALERT_SEVERITIES: tuple[AlertSeverity, ...] = ("warning", "critical")
#: What raises alerts (relay.inspection.alerts): a new kind is added here, where webhooks' ``events`` are checked.
ALERT_KINDS: Final = ("anomaly", "changed", "threshold", "mission_aborted", "schedule_missed", "schedule_failed")
#: The webhook event of an acknowledgement (a raised alert's event is ``alert.raised``, filtered by its kind).
ALERT_ACKNOWLEDGED: Final = "alert.acknowledged"


@dataclass(frozen=True, slots=True)
class Target:
    """A point of interest: a barrel, a panel, a valve."""

    id: str  # letters, digits, _ and -; unique
    name: str  # shown to operators
    kind: str  # e.g. "gas", "temperature", "valve"
    x: float
    y: float
    facing: float | None = None  # yaw (rad) a robot should have when it looks at the target; None: face it


@dataclass(frozen=True, slots=True)
class Step:
    """One step of a mission. ``inspect``: go to the target's standoff pose facing it, then capture.
    ``goto``: go to (x, y, yaw). ``capture``: take the camera image and the readings here. ``dwell``: wait."""

    kind: StepKind
    target: str | None = None  # inspect, capture (optional)
    x: float | None = None  # goto
    y: float | None = None
    yaw: float | None = None
    seconds: float | None = None  # dwell


@dataclass(frozen=True, slots=True)
class MissionRecord:
    id: str
    name: str
    robot: str
    steps: tuple[Step, ...]
    state: MissionState
    current: int  # index of the step being done (== len(steps) when done)
    reason: str  # why it is in its state ("" when there is nothing to say)
    created: float
    updated: float
    owner: str = ""  # the client id of the operator who started it


@dataclass(frozen=True, slots=True)
class CaptureRecord:
    id: str
    robot: str
    t: float
    x: float
    y: float
    yaw: float
    readings: dict[str, float] = field(default_factory=dict)  # sensor name -> value (units from robots.yaml)
    mission: str | None = None
    target: str | None = None
    image: str | None = None  # sha256 hex of the JPEG kept beside the database; None: no camera image
    width: int = 0
    height: int = 0


@dataclass(frozen=True, slots=True)
class ReadingTrend:
    """A reading of a target over its last rounds, as a finding keeps it (relay.inspection.trend): ``points`` are
    (Unix s, value), oldest first; ``threshold`` the limit they are measured against (None: the sensor has none)."""

    sensor: str
    unit: str
    threshold: float | None
    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True, slots=True)
class FindingRecord:
    id: str
    capture: str  # the capture it is about
    robot: str
    x: float  # where (the target's position, else the capture's)
    y: float
    status: FindingStatus
    note: str
    source: Literal["operator", "rule"]
    created: float
    updated: float
    mission: str | None = None
    target: str | None = None
    region: tuple[tuple[int, int], ...] | None = None  # outline in image pixels (u right, v down), None: none
    #: For a change finding (relay.inspection.change_watch): the changed share of the view (0-1) and the capture
    #: it was compared with, so that a card can show before and after; None for every other finding.
    change: float | None = None
    baseline: str | None = None
    #: The readings the finding was judged on, over the target's last rounds (the trend finding's reading, else the
    #: one nearest its limit), kept as they were then: a later round or a new limit does not rewrite the evidence.
    trend: ReadingTrend | None = None


@dataclass(frozen=True, slots=True)
class AlertRecord:
    """Something a person must see and acknowledge (relay.inspection.alerts): raised by the relay, acknowledged once."""

    id: str
    kind: str  # what raised it: "anomaly", "threshold", "mission_aborted", ... (webhooks filter on it)
    robot: str | None
    subject: str | None  # the finding, capture, mission or target it is about
    text: str  # for people: "Anomaly at Spill (robot2): gas 312.0 ppm (over 200 ppm)"
    severity: AlertSeverity
    raised: float
    acked_by: str | None = None  # the operator's name (their client id when they gave none); None: not yet
    acked_at: float | None = None
    ack_note: str = ""


@dataclass(frozen=True, slots=True)
class DeliveryRecord:
    """One attempt to POST an event to a webhook (relay.inspection.webhooks), and how it ended. No secret in it."""

    id: str
    endpoint: str  # the URL without user, password, query or fragment
    event: str  # "alert.raised" or "alert.acknowledged"
    alert: str
    attempt: int  # 1, 2, ...
    t: float  # when it was sent (Unix seconds)
    status: int | None  # the HTTP status, None: no answer (refused, unreachable, timed out)
    outcome: str  # "delivered", "retrying", "refused" (not retried: 4xx, 3xx), "failed" (gave up)
    detail: str  # why, when it did not succeed


@dataclass(frozen=True, slots=True)
class ScheduleRecord:
    """A mission started at times (relay.inspection.schedule_rules reads ``start`` .. ``blackouts``).

    ``mission`` is the ``mission/start`` command's form without ``id``: ``{"file"}``, ``{"targets"}`` or
    ``{"robot", "steps"}``, with an optional ``name``. ``windows``: ``(days, first_hour, last_hour)`` each;
    ``blackouts``: ``(start, end)`` each (Unix seconds)."""

    id: str  # the schedule's name: letters, digits, _ and -; unique
    mission: dict[str, Any]
    start: float
    repeat: float  # seconds between runs (the rules' interval; "interval" is a PostgreSQL keyword)
    windows: tuple[tuple[tuple[int, ...], int, int], ...]
    blackouts: tuple[tuple[float, float], ...]
    priority: int  # higher first when runs are due together
    on_busy: Literal["wait", "skip"]
    created: float
    updated: float
    owner: str  # who made or last changed it


ScheduleOutcome = Literal["started", "skipped", "missed", "failed"]


@dataclass(frozen=True, slots=True)
class ScheduleRun:
    """What became of one run of a schedule: ``started`` (``mission`` names it), ``skipped``, ``missed`` or
    ``failed`` (``reason`` says why)."""

    id: str
    schedule: str
    slot: float  # when it was due (Unix seconds)
    t: float  # when this was decided
    outcome: ScheduleOutcome
    mission: str | None
    reason: str


def new_id(prefix: str, random_bytes: int = 3) -> str:
    """A record's id: its kind, when it was made (local time, to the second) and 24 random bits; records made in
    bursts (alerts, webhook deliveries: hundreds a second) take more, so that two of one second never meet."""
    return f"{prefix}-{time.strftime('%Y%m%d-%H%M%S')}-{secrets.token_hex(random_bytes)}"
