"""Schedules and their runs in the inspection database (relay/inspection/schedule_store.py), on SQLite and on a
PostgreSQL server (the fixtures of tests/test_store.py)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from relay.inspection.records import ScheduleRecord, ScheduleRun
from relay.inspection.schema import MIGRATIONS
from relay.inspection.store import Store
from tests.helpers.databases import BUSY


@pytest.fixture
def store(url: str, tmp_path: Path) -> Iterator[Store]:
    with Store.open(url, tmp_path / "images", busy_timeout=BUSY) as opened:
        yield opened


def nightly(**changes: object) -> ScheduleRecord:
    fields: dict[str, object] = {
        "id": "nightly",
        "mission": {"targets": ["spill", "leak"], "name": "rounds"},
        "start": 1795388400.0,
        "repeat": 3600.0,
        "windows": (((0, 1, 2, 3, 4), 8, 17),),
        "blackouts": ((1795400000.0, 1795403600.0),),
        "priority": 2,
        "on_busy": "wait",
        "created": 1795380000.0,
        "updated": 1795380000.0,
        "owner": "c-1",
    }
    fields.update(changes)
    return ScheduleRecord(**fields)  # type: ignore[arg-type]


def test_a_schedule_is_kept_as_given_and_replaced_by_name(store: Store) -> None:
    assert store.add_schedule(nightly())
    assert store.schedule("nightly") == nightly()
    # A second add of the name changes nothing.
    assert not store.add_schedule(nightly(priority=9))
    assert store.schedule("nightly") == nightly()
    store.save_schedule(nightly(repeat=7200.0, blackouts=(), on_busy="skip", updated=1795390000.0))
    assert store.schedules() == [nightly(repeat=7200.0, blackouts=(), on_busy="skip", updated=1795390000.0)]


def test_runs_are_recorded_and_the_latest_of_each_schedule_is_found(store: Store) -> None:
    store.add_schedule(nightly())
    store.add_schedule(nightly(id="weekly", mission={"file": "demo"}))
    runs = [
        ScheduleRun("r-1", "nightly", 100.0, 101.0, "started", "m-1.robot1", ""),
        ScheduleRun("r-2", "nightly", 3700.0, 9000.0, "missed", None, "the relay was down"),
        ScheduleRun("r-3", "weekly", 50.0, 60.0, "skipped", None, "robot1 is emergency-stopped"),
    ]
    for run in runs:
        store.add_schedule_run(run)
    assert store.schedule_runs("nightly") == [runs[1], runs[0]]
    assert store.last_schedule_runs() == {"nightly": runs[1], "weekly": runs[2]}
    # Removing a schedule removes its runs; the other's stay.
    assert store.remove_schedule("nightly")
    assert not store.remove_schedule("nightly")
    assert [s.id for s in store.schedules()] == ["weekly"]
    assert store.schedule_runs("nightly") == []
    assert store.last_schedule_runs() == {"weekly": runs[2]}


def test_schedules_outlive_the_store(url: str, tmp_path: Path) -> None:
    with Store.open(url, tmp_path / "images", busy_timeout=BUSY) as first:
        first.add_schedule(nightly())
        first.add_schedule_run(ScheduleRun("r-1", "nightly", 100.0, 101.0, "started", "m-1.robot1", ""))
        assert first.schema_version == len(MIGRATIONS)
    with Store.open(url, tmp_path / "images", busy_timeout=BUSY) as again:
        assert again.schedules() == [nightly()]
        assert again.last_schedule_runs()["nightly"].mission == "m-1.robot1"
