"""The schedule rules (relay/inspection/schedule_rules.py) with times moved by hand: no clock, no I/O."""

from __future__ import annotations

import re
from datetime import UTC, datetime
from zoneinfo import ZoneInfo

import pytest

from relay.inspection.schedule_rules import (
    MAX_MISSED,
    Blackout,
    ScheduleError,
    Timing,
    Window,
    check,
    deadline,
    next_run,
    pending,
    weekday_numbers,
)

BERLIN = ZoneInfo("Europe/Berlin")
WEEKDAYS = (0, 1, 2, 3, 4)


def at(text: str, tz: ZoneInfo = BERLIN) -> float:
    """Unix time of a local date-time in ``tz`` (``2026-11-23 08:00``: a Monday)."""
    return datetime.fromisoformat(text).replace(tzinfo=tz).timestamp()


def hourly_office_hours(**changes: object) -> Timing:
    """Every hour from Monday 23 Nov 2026 08:00 Berlin, weekdays 8-17."""
    fields: dict[str, object] = {
        "start": at("2026-11-23 08:00"),
        "interval": 3600.0,
        "windows": (Window(WEEKDAYS, 8, 17),),
    }
    fields.update(changes)
    return Timing(**fields)  # type: ignore[arg-type]


def test_the_next_run_is_the_next_slot_inside_a_window() -> None:
    timing = hourly_office_hours()
    assert next_run(timing, at("2026-11-23 07:00"), BERLIN) == at("2026-11-23 08:00")
    assert next_run(timing, at("2026-11-23 08:00:01"), BERLIN) == at("2026-11-23 09:00")
    # 16:00 is the last slot of the day (17:00 is the window's end, outside it); the next is Tuesday 08:00.
    assert next_run(timing, at("2026-11-23 16:30"), BERLIN) == at("2026-11-24 08:00")
    # Friday evening: Monday morning.
    assert next_run(timing, at("2026-11-27 17:00"), BERLIN) == at("2026-11-30 08:00")


def test_slots_off_the_window_grid_start_at_the_first_slot_inside() -> None:
    # Every 7 minutes from 07:58: the first slot in the window is 08:05, not 08:00.
    timing = hourly_office_hours(start=at("2026-11-23 07:58"), interval=420.0)
    assert next_run(timing, at("2026-11-23 07:00"), BERLIN) == at("2026-11-23 08:05")


def test_a_blackout_holds_runs_back_until_it_ends() -> None:
    blackout = Blackout(at("2026-11-23 10:30"), at("2026-11-23 13:00"))
    timing = hourly_office_hours(blackouts=(blackout,))
    assert next_run(timing, at("2026-11-23 10:01"), BERLIN) == at("2026-11-23 13:00")
    # The 10:00 run may start until the blackout begins, not until 11:00.
    assert deadline(timing, at("2026-11-23 10:00"), BERLIN) == at("2026-11-23 10:30")


def test_a_run_may_start_until_its_deadline_and_is_missed_after() -> None:
    timing = hourly_office_hours(interval=6 * 3600.0)  # 08:00 and 14:00 in the window (20:00, 02:00 are not)
    first = at("2026-11-23 08:00")
    due = pending(timing, None, at("2026-11-23 08:20"), BERLIN)
    assert (due.missed, due.due, due.deadline) == ((), first, at("2026-11-23 14:00"))
    # 14:00's run may start until the window closes at 17:00, not until the next slot at 20:00.
    assert deadline(timing, at("2026-11-23 14:00"), BERLIN) == at("2026-11-23 17:00")
    late = pending(timing, first, at("2026-11-23 17:00"), BERLIN)
    assert (late.missed, late.due) == ((at("2026-11-23 14:00"),), None)
    # Nothing owed before the next run.
    assert pending(timing, first, at("2026-11-23 13:59"), BERLIN).due is None


def test_runs_missed_while_the_relay_was_down_are_listed_never_started_late() -> None:
    timing = hourly_office_hours()
    # Down from Monday 08:30 to Tuesday 08:10: Monday 09:00-16:00 were missed; Tuesday 08:00 may still start.
    owed = pending(timing, at("2026-11-23 08:00"), at("2026-11-24 08:10"), BERLIN)
    assert owed.missed == tuple(at(f"2026-11-23 {h:02d}:00") for h in range(9, 17))
    assert (owed.more, owed.due) == (0, at("2026-11-24 08:00"))
    # Back at Tuesday 18:00: Tuesday's runs were all missed, none is due (the window is closed).
    closed = pending(timing, at("2026-11-23 16:00"), at("2026-11-24 18:00"), BERLIN)
    assert len(closed.missed) == 9 and closed.due is None


def test_a_long_outage_lists_a_few_missed_runs_and_counts_the_rest() -> None:
    timing = Timing(at("2026-11-01 00:00"), 60.0, (Window(tuple(range(7)), 0, 24),))
    owed = pending(timing, None, at("2026-12-01 00:00:30"), BERLIN)  # a month of minute runs
    assert len(owed.missed) == MAX_MISSED and owed.missed[0] == at("2026-11-01 00:00")
    assert 30 * 1440 - MAX_MISSED - 2 <= owed.more <= 30 * 1440
    assert owed.due == at("2026-12-01 00:00")


def test_windows_follow_the_local_clock_across_summer_time() -> None:
    # Daily at 09:00 Berlin from a March Saturday: after the change to summer time (29 Mar 2026) the run is still
    # at 09:00 local only if the interval were a calendar day; with 24 h it is at 10:00 local, still in the window.
    timing = Timing(at("2026-03-28 09:00"), 86400.0, (Window(tuple(range(7)), 9, 11),))
    assert next_run(timing, at("2026-03-29 00:00"), BERLIN) == at("2026-03-29 10:00")
    # A window of 9-10 local excludes it: the next runs inside are none within the horizon.
    narrow = Timing(at("2026-03-28 09:00"), 86400.0, (Window(tuple(range(7)), 9, 10),))
    assert next_run(narrow, at("2026-03-29 00:00"), BERLIN) == at("2026-10-25 09:00")  # back to winter time


def test_utc_and_local_zones_read_the_same_instant_differently() -> None:
    timing = Timing(datetime(2026, 11, 23, 7, tzinfo=UTC).timestamp(), 3600.0, (Window(WEEKDAYS, 8, 9),))
    assert next_run(timing, timing.start, UTC) == datetime(2026, 11, 23, 8, tzinfo=UTC).timestamp()
    assert next_run(timing, timing.start, BERLIN) == timing.start  # 07:00 UTC is 08:00 in Berlin


def test_a_schedule_that_can_never_run_has_no_next_run() -> None:
    blackout = Blackout(at("2026-01-01 00:00"), at("2030-01-01 00:00"))
    assert next_run(hourly_office_hours(blackouts=(blackout,)), at("2026-11-23 07:00"), BERLIN) is None


@pytest.mark.parametrize(
    ("timing", "says"),
    [
        (Timing(0.0, 3600.0, ()), "needs at least one window"),
        (Timing(0.0, 59.0, (Window((0,), 8, 9),)), "repeat must be at least 60 s"),
        (Timing(0.0, 60.0, (Window((7,), 8, 9),)), "windows[0].days"),
        (Timing(0.0, 60.0, (Window((0,), 9, 9),)), "windows[0]: hours"),
        (Timing(0.0, 60.0, (Window((0,), 8, 25),)), "windows[0]: hours"),
        (Timing(0.0, 60.0, (Window((0,), 8, 9),), (Blackout(5.0, 5.0),)), "blackouts[0]"),
        (Timing(float("nan"), 60.0, (Window((0,), 8, 9),)), "start must be a time"),
    ],
)
def test_a_schedule_that_cannot_run_is_refused_naming_why(timing: Timing, says: str) -> None:
    with pytest.raises(ScheduleError, match=re.escape(says)):
        check(timing)


def test_weekday_names() -> None:
    assert weekday_numbers(["Mon", "friday", "mon"]) == (0, 4)
    with pytest.raises(ScheduleError, match="unknown weekday 'funday'"):
        weekday_numbers(["funday"])
