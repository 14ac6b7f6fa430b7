"""When a schedule's runs are due, without I/O and without a clock: the time is always passed in.

A schedule (relay.inspection.scheduler carries it out) has a **start** and a **repeat interval** (at least 60 s):
its slots are ``start + k * interval``. A slot is a run when it falls in one of its **windows** (weekdays and hours
of the relay's local time, ``[first_hour, last_hour)``) and outside every **blackout** (a time range). A run may
start from its slot until its **deadline**: the end of its window, the start of the next blackout, or the next
slot, whichever comes first. A run not started by then is **missed**: it is never started late outside its window.

Times are Unix seconds; windows are read in the time zone passed in (``tz``: the relay's local zone), so a window
follows the wall clock across summer time. Tested with times moved by hand (tests/test_schedule_rules.py).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta, tzinfo
from typing import Final, Literal

OnBusy = Literal["wait", "skip"]
ON_BUSY: tuple[OnBusy, ...] = ("wait", "skip")
#: The shortest repeat interval (seconds): a mission takes minutes, and each run is a database row and a message.
MIN_INTERVAL: Final = 60.0
#: How far ahead a next run is looked for (days): a schedule with no run within a year says "none".
HORIZON_DAYS: Final = 400
#: Most missed runs listed at once (a relay down for a month with a 60 s interval missed 43 200): the rest counted.
MAX_MISSED: Final = 20
#: Bounds of the jumps over closed windows and blackouts, so that no input makes a search run long.
_MAX_JUMPS: Final = 4000
WEEKDAYS: Final = ("mon", "tue", "wed", "thu", "fri", "sat", "sun")


class ScheduleError(ValueError):
    """A schedule that cannot run; the message names the field and what was expected."""


@dataclass(frozen=True, slots=True)
class Window:
    """Weekdays (0 Monday .. 6 Sunday) and the hours ``[first_hour, last_hour)`` of the local day (24: midnight)."""

    days: tuple[int, ...]
    first_hour: int
    last_hour: int


@dataclass(frozen=True, slots=True)
class Blackout:
    """A time range ``[start, end)`` (Unix seconds) in which no run starts."""

    start: float
    end: float


@dataclass(frozen=True, slots=True)
class Timing:
    """When a schedule runs: what the rules read of it."""

    start: float
    interval: float
    windows: tuple[Window, ...]
    blackouts: tuple[Blackout, ...] = ()


@dataclass(frozen=True, slots=True)
class Pending:
    """What is owed at a time: runs whose deadline passed (at most ``MAX_MISSED``, oldest first; ``more``: at most
    that many others) and the run that may start now (None: none), with its deadline."""

    missed: tuple[float, ...]
    more: int
    due: float | None
    deadline: float | None
    #: The latest slot of those missed (listed or counted): where the next look starts. None: none missed.
    last_missed: float | None = None


def check(timing: Timing) -> None:
    """ScheduleError naming what is wrong: no window, an interval under ``MIN_INTERVAL``, a bad day, hour or range."""
    if not (math.isfinite(timing.start) and timing.start >= 0):
        raise ScheduleError(f"start must be a time (Unix seconds), got {timing.start!r}")
    if not (math.isfinite(timing.interval) and timing.interval >= MIN_INTERVAL):
        raise ScheduleError(f"repeat must be at least {MIN_INTERVAL:g} s, got {timing.interval!r}")
    if not timing.windows:
        raise ScheduleError("a schedule needs at least one window (days and hours)")
    for n, window in enumerate(timing.windows):
        if not window.days or any(d not in range(7) for d in window.days):
            raise ScheduleError(f"windows[{n}].days must be weekdays ({', '.join(WEEKDAYS)})")
        if not 0 <= window.first_hour < window.last_hour <= 24:
            raise ScheduleError(
                f"windows[{n}]: hours must be 0 <= first < last <= 24, got {window.first_hour}-{window.last_hour}"
            )
    for n, blackout in enumerate(timing.blackouts):
        if not (math.isfinite(blackout.start) and math.isfinite(blackout.end) and blackout.start < blackout.end):
            raise ScheduleError(f"blackouts[{n}] must be a time range with start before end")


def open_window_end(timing: Timing, t: float, tz: tzinfo) -> float | None:
    """The end of the window ``t`` is in (the latest, where windows overlap or join), or None outside every one."""
    end: float | None = None
    probe = t
    for _ in range(8 * len(timing.windows) + 2):  # joined windows: at most one a day and window for a week
        found = _window_end_at(timing.windows, probe, tz)
        if found is None or (end is not None and found <= end):
            break
        end = found
        probe = found
    return end


def _window_end_at(windows: Sequence[Window], t: float, tz: tzinfo) -> float | None:
    local = datetime.fromtimestamp(t, tz)
    ends = [
        _at(local, w.last_hour, tz)
        for w in windows
        if local.weekday() in w.days and w.first_hour <= local.hour < w.last_hour
    ]
    return max(ends) if ends else None


def _at(local: datetime, hour: int, tz: tzinfo) -> float:
    """Unix time of ``hour`` o'clock (24: the next midnight) on ``local``'s day, in ``tz``."""
    day = datetime(local.year, local.month, local.day, tzinfo=tz)
    if hour == 24:
        nxt = day.date() + timedelta(days=1)
        return datetime(nxt.year, nxt.month, nxt.day, tzinfo=tz).timestamp()
    return datetime(day.year, day.month, day.day, hour, tzinfo=tz).timestamp()


def _next_opening(timing: Timing, t: float, tz: tzinfo) -> float | None:
    """The first time at or after ``t`` inside a window (``t`` itself when it is in one), within a week."""
    if _window_end_at(timing.windows, t, tz) is not None:
        return t
    local = datetime.fromtimestamp(t, tz)
    best: float | None = None
    for ahead in range(8):
        date = local.date() + timedelta(days=ahead)
        day = datetime(date.year, date.month, date.day, tzinfo=tz)
        for window in timing.windows:
            if day.weekday() in window.days:
                opening = _at(day, window.first_hour, tz)
                if opening >= t and (best is None or opening < best):
                    best = opening
        if best is not None:
            return best
    return None


def _blackout_at(timing: Timing, t: float) -> Blackout | None:
    return next((b for b in timing.blackouts if b.start <= t < b.end), None)


def slot_at_or_after(timing: Timing, t: float) -> float:
    """The first slot ``start + k * interval`` at or after ``t``."""
    if t <= timing.start:
        return timing.start
    return timing.start + math.ceil((t - timing.start) / timing.interval - 1e-9) * timing.interval


def slot_after(timing: Timing, t: float) -> float:
    """The first slot strictly after ``t`` (a slot itself is not after itself: a relative tolerance, not an epsilon
    added to a time of 1.8e9, which rounds away)."""
    if t < timing.start:
        return timing.start
    return timing.start + (math.floor((t - timing.start) / timing.interval + 1e-9) + 1) * timing.interval


def runs(timing: Timing, t: float, tz: tzinfo) -> bool:
    """Whether slot ``t`` is a run: in a window and in no blackout."""
    return _blackout_at(timing, t) is None and _window_end_at(timing.windows, t, tz) is not None


def next_run(timing: Timing, after: float, tz: tzinfo, *, strictly: bool = False) -> float | None:
    """The first run at or after ``after`` (``strictly``: after it), or None within ``HORIZON_DAYS`` (closed windows
    and blackouts are jumped over, not walked slot by slot)."""
    horizon = after + HORIZON_DAYS * 86400.0
    slot = slot_after(timing, after) if strictly else slot_at_or_after(timing, after)
    for _ in range(_MAX_JUMPS):
        if slot > horizon:
            return None
        blackout = _blackout_at(timing, slot)
        if blackout is not None:
            slot = slot_at_or_after(timing, blackout.end)
            continue
        opening = _next_opening(timing, slot, tz)
        if opening is None:
            return None
        if opening == slot:
            return slot
        slot = slot_at_or_after(timing, opening)
    return None


def deadline(timing: Timing, slot: float, tz: tzinfo) -> float:
    """Until when the run of ``slot`` may start: its window's end, the next blackout's start, or the next slot."""
    ends = [slot + timing.interval, open_window_end(timing, slot, tz) or slot]
    ends += [b.start for b in timing.blackouts if b.start > slot]
    return min(ends)


def pending(timing: Timing, after: float | None, now: float, tz: tzinfo) -> Pending:
    """What is owed at ``now`` for the runs after ``after`` (the last slot already handled; None: none yet): the
    runs whose deadline passed (missed), and the one that may start now."""
    missed: list[float] = []
    more = 0
    last: float | None = None
    slot = next_run(timing, timing.start, tz) if after is None else next_run(timing, after, tz, strictly=True)
    for _ in range(_MAX_JUMPS):
        if slot is None or slot > now:
            return Pending(tuple(missed), more, None, None, last)
        end = deadline(timing, slot, tz)
        if now < end:
            return Pending(tuple(missed), more, slot, end, last)
        last = slot
        if len(missed) < MAX_MISSED:
            missed.append(slot)
            slot = next_run(timing, slot, tz, strictly=True)
            continue
        # The list is full: every slot before ``now - interval`` is past its deadline, so jump there and count the
        # slots jumped over (an upper bound of the runs among them) instead of walking them.
        skip_to = max(slot, now - timing.interval)
        more += 1 + max(0, math.floor((skip_to - slot) / timing.interval - 1e-9))
        slot = next_run(timing, skip_to, tz, strictly=True)
    return Pending(tuple(missed), more, None, None, last)


def weekday_numbers(names: Sequence[str]) -> tuple[int, ...]:
    """``["mon", "fri"]`` -> ``(0, 4)``; ScheduleError naming an unknown day."""
    days = []
    for name in names:
        key = str(name).strip().lower()[:3]
        if key not in WEEKDAYS:
            raise ScheduleError(f"unknown weekday {str(name)[:20]!r} (use {', '.join(WEEKDAYS)})")
        days.append(WEEKDAYS.index(key))
    return tuple(sorted(set(days)))
