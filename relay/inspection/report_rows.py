"""The report's words, without I/O: local times, rooms, readings with units and limits, statuses, reviews, the
time range a request names, and findings as work orders (relay.inspection.report writes them out).

Times in the store are Unix seconds; a plant manager reads the site's wall clock. CSV and JSON carry ISO 8601 with
the offset (``2026-11-24T14:03:12+01:00``: a spreadsheet and ``datetime.fromisoformat`` read it, and it says which
zone); HTML carries a readable local date-time with the zone's abbreviation. The zone is ``site.time_zone`` of
robots.yaml (an IANA name) when given, else the relay's local zone (the ``TZ`` environment variable, else the
system's): ``zone`` below is a ``ZoneInfo`` or None for that local zone.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import date, datetime, timedelta, tzinfo

from ..sim.floorplan import Room as Room  # a named area of the site: its bounds in the map frame
from .records import CaptureRecord, FindingRecord, MissionRecord
from .trend import Trend

#: A finding's status as people say it (the store keeps the code).
STATUS_WORDS = {
    "ok": "OK", "anomaly": "Anomaly", "needs_review": "Needs review", "changed": "Changed since last round",
    "false_alarm": "False alarm",
}  # fmt: skip
#: Work orders come from findings that need someone: an anomaly now, a finding to review soon; a place that changed
#: since the last round is one to go and look at, as a finding to review is (the change alone says nothing of
#: danger: readings past a limit make their own anomaly). OK findings and false alarms make none.
PRIORITIES = {"anomaly": "high", "needs_review": "medium", "changed": "medium"}
#: When a work order is due, counted from the capture that showed it: a day for an anomaly (a leak, a hot panel is
#: fixed or made safe within a shift or two), a week for something to look at again.
DUE_AFTER = {"high": timedelta(days=1), "medium": timedelta(days=7)}
#: Ranges a request may name: a date (``2026-11-24``: the whole day, in the site's zone) or a date-time with or
#: without an offset (``2026-11-24T08:00``, ``2026-11-24T08:00:00+01:00``; without one, in the site's zone).
_DATE = re.compile(r"\d{4}-\d{2}-\d{2}")


class RangeError(ValueError):
    """A time range that cannot be read; the message names the parameter and what was expected."""


@dataclass(frozen=True)
class Limit:
    """A sensor's unit and warning thresholds, from robots.yaml (``robots[].sensors[]``)."""

    unit: str
    warn_above: float | None = None
    warn_below: float | None = None


@dataclass(frozen=True)
class SiteInfo:
    """What a report needs to know of the site beyond the database."""

    name: str
    zone: tzinfo | None  # None: the relay's local zone
    rooms: tuple[Room, ...] = ()
    limits: Mapping[str, Mapping[str, Limit]] = field(default_factory=dict)  # robot -> sensor -> its limit
    targets: Mapping[str, str] = field(default_factory=dict)  # target id -> name


# -- times ------------------------------------------------------------------------------------------------------


def local_time(t: float, zone: tzinfo | None) -> datetime:
    """``t`` (Unix seconds) on the site's clock, with its offset (the local zone's at that instant: DST counts)."""
    return datetime.fromtimestamp(t, zone) if zone is not None else datetime.fromtimestamp(t).astimezone()


def iso_time(t: float, zone: tzinfo | None) -> str:
    """ISO 8601 with the offset, to the second: ``2026-11-24T14:03:12+01:00``."""
    return local_time(t, zone).isoformat(timespec="seconds")


def readable_time(t: float, zone: tzinfo | None) -> str:
    """``Tue 24 Nov 2026, 14:03:12 CET``: the day, the date, the wall-clock time and the zone's abbreviation."""
    when = local_time(t, zone)
    return f"{_WEEKDAYS[when.weekday()]} {when.day} {_MONTHS[when.month - 1]} {when.year}, {when:%H:%M:%S} " + (
        when.tzname() or _offset(when)
    )


def readable_date(day: date) -> str:
    return f"{day.day} {_MONTHS[day.month - 1]} {day.year}"


def zone_label(zone: tzinfo | None, now: float) -> str:
    """The zone as the report's header names it: ``Europe/Berlin (UTC+01:00)``, or ``the relay's local time
    (CET, UTC+01:00)``."""
    when = local_time(now, zone)
    key = getattr(zone, "key", None)
    if key:
        return f"{key} (UTC{_offset(when)})"
    return f"the relay's local time ({when.tzname()}, UTC{_offset(when)})"


def _offset(when: datetime) -> str:
    return when.isoformat()[-6:]  # an aware datetime's isoformat ends with its offset, +00:00 included


# Names written out here: strftime's %a and %b follow the process's locale, and a report must read the same
# whatever locale the relay was started in.
_WEEKDAYS = ("Mon", "Tue", "Wed", "Thu", "Fri", "Sat", "Sun")
_MONTHS = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")


def parse_range(start: str | None, end: str | None, zone: tzinfo | None) -> tuple[float, float]:
    """``from`` and ``to`` of a range request as Unix seconds, ``[from, to)``: a date ``to`` includes its whole
    day. RangeError naming the parameter (its value clipped) when one is missing, unreadable or not before the
    other."""
    if start is None or end is None:
        missing = "from" if start is None else "to"
        raise RangeError(f"'{missing}' is required: a date (2026-11-24) or a date-time (2026-11-24T08:00+01:00)")
    first = _instant(start, "from", zone, end_of_day=False)
    last = _instant(end, "to", zone, end_of_day=True)
    if first >= last:
        raise RangeError(f"'from' ({start[:40]}) must be before 'to' ({end[:40]})")
    return first, last


def _instant(text: str, name: str, zone: tzinfo | None, *, end_of_day: bool) -> float:
    text = text.strip()
    try:
        if _DATE.fullmatch(text):
            day = date.fromisoformat(text)
            if end_of_day:
                day += timedelta(days=1)
            when = datetime(day.year, day.month, day.day)
        else:
            when = datetime.fromisoformat(text)
    except (ValueError, OverflowError):
        raise RangeError(
            f"'{name}' must be a date (2026-11-24) or an ISO 8601 date-time (2026-11-24T08:00+01:00), got {text[:40]!r}"
        ) from None
    if when.tzinfo is None:  # a wall-clock time of the site
        when = when.replace(tzinfo=zone) if zone is not None else when.astimezone()
    return when.timestamp()


# -- places, readings, statuses ---------------------------------------------------------------------------------


def room_at(rooms: Sequence[Room], x: float, y: float) -> Room | None:
    """The room holding (x, y). Rooms' bounds include their walls, so neighbours share an edge: a point on it is
    in the room whose centre is nearer."""
    holding = [r for r in rooms if r.contains(x, y)]
    return min(
        holding,
        key=lambda r: math.hypot(x - 0.5 * (r.min_x + r.max_x), y - 0.5 * (r.min_y + r.max_y)),
        default=None,
    )


def status_words(status: str) -> str:
    return STATUS_WORDS.get(status) or status.replace("_", " ").capitalize()


def number(value: float) -> str:
    """A reading as people write it: one decimal from 1 up (698.2, 4.0), three significant digits under
    (0.512, 0.0123); never an exponent."""
    if not math.isfinite(value):
        return str(value)
    if abs(value) >= 1 or value == 0:
        return f"{value:.1f}"
    return f"{value:.3g}" if abs(value) >= 1e-4 else f"{value:.6f}"


@dataclass(frozen=True)
class Reading:
    """One value of a capture with what robots.yaml says of its sensor (no limit known: unit "" and no limits)."""

    sensor: str
    value: float
    limit: Limit

    @property
    def over(self) -> str | None:
        """ "above" or "below" when the value is past a warning threshold, else None."""
        if self.limit.warn_above is not None and self.value > self.limit.warn_above:
            return "above"
        if self.limit.warn_below is not None and self.value < self.limit.warn_below:
            return "below"
        return None

    def text(self) -> str:
        """``gas 698.2 ppm (limit 400 ppm): over the limit``; ``temperature 27.3 °C (limit 45 °C)``."""
        unit = f" {self.limit.unit}" if self.limit.unit else ""
        above, below = self.limit.warn_above, self.limit.warn_below
        if above is not None and below is not None:
            bounds = f" (range {below:g} to {above:g}{unit})"
        elif above is not None:
            bounds = f" (limit {above:g}{unit})"
        elif below is not None:
            bounds = f" (minimum {below:g}{unit})"
        else:
            bounds = ""
        verdict = {"above": ": over the limit", "below": ": under the minimum"}.get(self.over or "", "")
        return f"{self.sensor} {number(self.value)}{unit}{bounds}{verdict}"


def readings_of(capture: CaptureRecord | None, limits: Mapping[str, Limit]) -> tuple[Reading, ...]:
    if capture is None:
        return ()
    return tuple(Reading(name, value, limits.get(name, Limit(""))) for name, value in capture.readings.items())


@dataclass(frozen=True)
class Row:
    """A finding as the report shows it: numbered as on the plan, with its capture, room, readings and times, and
    what the target was before: ``before``, the previous capture compared with (a change finding's baseline, else
    the target's previous capture with an image), and ``trends``, each reading over the target's last rounds up to
    this capture (relay.inspection.report.with_history reads them)."""

    number: int
    finding: FindingRecord
    capture: CaptureRecord | None
    room: Room | None
    target_name: str
    readings: tuple[Reading, ...]
    before: CaptureRecord | None = None
    trends: tuple[Trend, ...] = ()

    def trend(self, sensor: str) -> Trend | None:
        return next((t for t in self.trends if t.sensor == sensor), None)

    @property
    def time(self) -> float:
        """When it was seen: the capture's time (a finding made later about an old capture is about then)."""
        return self.capture.t if self.capture is not None else self.finding.created

    @property
    def status(self) -> str:
        return status_words(self.finding.status)

    @property
    def location(self) -> str:
        return self.room.title if self.room is not None else ""

    def review(self, zone: tzinfo | None) -> str:
        """Who decided the status, and when it last changed: ``Rule`` / ``Operator``, ``, updated <time>``. The
        store keeps no name for a change (only its source and time), so no name is shown."""
        who = "Operator" if self.finding.source == "operator" else "Rule (readings against limits)"
        if self.finding.updated > self.finding.created:
            return f"{who}, updated {readable_time(self.finding.updated, zone)}"
        return who


def rows_of(findings: Sequence[FindingRecord], captures: Mapping[str, CaptureRecord], site: SiteInfo) -> list[Row]:
    """The findings in the order given, numbered from 1. A finding's room is the one holding its place (its
    target's, else its capture's), else the one holding the capture's pose."""
    rows = []
    for i, f in enumerate(findings, 1):
        capture = captures.get(f.capture)
        room = room_at(site.rooms, f.x, f.y)
        if room is None and capture is not None:
            room = room_at(site.rooms, capture.x, capture.y)
        target = site.targets.get(f.target or "", f.target or "")
        readings = readings_of(capture, site.limits.get(f.robot, {}))
        rows.append(Row(i, f, capture, room, target, readings))
    return rows


# -- work orders ------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WorkOrder:
    """A finding that needs someone, in the fields an EAM's work-order import takes (Maximo, SAP PM, Fiix all
    take an asset, a location, a priority, a description, a target date and attachments by URL)."""

    reference: str  # the finding's id: the same finding exported twice is the same work order
    asset: str  # the target's id ("" when the finding is about no target)
    asset_name: str
    location: str  # the room's title ("" outside every room)
    location_code: str  # the room's name
    x: float
    y: float
    priority: str  # PRIORITIES
    description: str
    evidence_url: str  # the capture's image, absolute ("" without an image)
    reported: str  # ISO 8601 with offset: when the capture was taken
    due: str  # reported + DUE_AFTER[priority] (ISO 8601 with the offset of that instant)
    status: str  # the finding's status in words
    robot: str
    mission: str


WORK_ORDER_FIELDS = tuple(WorkOrder.__dataclass_fields__)


def work_orders(rows: Sequence[Row], zone: tzinfo | None, image_url: Callable[[str], str]) -> list[WorkOrder]:
    """One work order per row whose status has a priority; ``image_url(sha256)`` is the image's absolute URL."""
    orders = []
    for row in rows:
        f = row.finding
        priority = PRIORITIES.get(f.status)
        if priority is None:
            continue
        over = "; ".join(r.text() for r in row.readings if r.over)
        what = row.target_name or f"({f.x:.2f}, {f.y:.2f})"
        description = f"{status_words(f.status)} at {what}" + (f" in {row.location}" if row.location else "") + "."
        note = f.note.strip()
        description += f" Note: {note}{'' if note.endswith(('.', '!', '?')) else '.'}" if note else ""
        description += f" Readings past their limits: {over}." if over else ""
        image = row.capture.image if row.capture is not None else None
        seen = local_time(row.time, zone)
        due = local_time(row.time + DUE_AFTER[priority].total_seconds(), zone)
        orders.append(
            WorkOrder(
                f.id, f.target or "", row.target_name, row.location, row.room.name if row.room else "",
                round(f.x, 3), round(f.y, 3), priority, description, image_url(image) if image else "",
                seen.isoformat(timespec="seconds"), due.isoformat(timespec="seconds"),
                row.status, f.robot, f.mission or "",
            )
        )  # fmt: skip
    return orders


#: The stem of a range report's name: ``/report/range.html?from=...&to=...`` (mission ids start with ``m-``).
RANGE = "range"


@dataclass(frozen=True)
class Scope:
    """What a report covers: a mission or a fleet mission's group (``mission``), or the findings whose capture was
    taken in ``[start, end)`` (Unix seconds)."""

    mission: str | None = None
    start: float | None = None
    end: float | None = None

    @property
    def stem(self) -> str:
        return self.mission if self.mission is not None else RANGE


@dataclass(frozen=True)
class Report:
    scope: Scope
    site: SiteInfo
    missions: list[MissionRecord]
    rows: list[Row]
    made: float  # when the report was made (Unix seconds)
