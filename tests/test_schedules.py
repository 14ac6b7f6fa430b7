"""Schedules (issue #30 item 1) on a real relay with real WebSocket clients, the simulated fleet and a real SQLite
database, the schedule's time moved by hand (the relay's wall clock; its monotonic clock, leases and deadman, runs):
bad input refused naming it, a run started as a mission like any other, a busy robot waited for or skipped, a run
that pauses or is missed an alert, and runs missed while the relay was down recorded at start-up."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from relay.config import FleetConfig
from relay.inspection.records import ScheduleRun
from relay.inspection.store import Store
from tests.helpers.inspection import operator
from tests.helpers.schedules import EVERY_DAY, WAIT, HandClock, ask, listed_schedules, schedule_relay, schedule_state
from tests.wsclient import TestClient

T = TypeVar("T")


def _alerts(client: TestClient, kind: str) -> list[dict[str, Any]]:
    return [m for _, m in client.messages if m["identifier"] == "alert" and m["kind"] == kind]


def _stored(tmp_path: Path) -> Store:
    return Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "inspection-images")


async def _read(tmp_path: Path, read: Callable[[Store], T]) -> T:
    """What the relay's database holds, read on a connection of the test's own, off the loop."""

    def run() -> T:
        with _stored(tmp_path) as store:
            return read(store)

    return await asyncio.to_thread(run)


async def _runs(tmp_path: Path, name: str, count: int) -> list[ScheduleRun]:
    """The schedule's runs, oldest first, once ``count`` are stored (they are written after they are announced)."""
    deadline = time.monotonic() + WAIT
    while True:
        runs = await _read(tmp_path, lambda s: s.schedule_runs(name))
        if len(runs) >= count or time.monotonic() > deadline:
            return list(reversed(runs))
        await asyncio.sleep(0.1)


async def test_a_schedule_runs_its_mission_waits_for_a_busy_robot_skips_and_alerts(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    clock = HandClock(time.time())
    start = clock.now + 120.0
    running = await schedule_relay(fleet_config, tmp_path, clock)
    try:
        ana = await operator(running)
        viewer = await TestClient.open(running.ws_url)
        await viewer.hello()
        nightly = {
            "identifier": "schedule/add", "schedule": "nightly", "start": start, "repeat": 3600, "windows": EVERY_DAY,
            "mission": {"robot": "robot1", "steps": [{"dwell": 60}], "name": "rounds"},
        }  # fmt: skip

        # Bad input: an error naming it, and nothing changes.
        bad: list[tuple[dict[str, Any], str, str]] = [
            ({"repeat": 59}, "bad_request", "repeat must be at least 60 s"),
            ({"windows": []}, "bad_request", "field 'windows'"),
            ({"windows": [{"days": ["funday"], "hours": [8, 17]}]}, "bad_request", "unknown weekday 'funday'"),
            ({"windows": [{"days": ["mon"], "hours": [17, 8]}]}, "bad_request", "hours must be 0 <= first < last"),
            ({"mission": {"targets": ["spill", "gone"]}}, "bad_request", "unknown target(s) gone"),
            ({"mission": {"robot": "robot1", "steps": [{"inspect": "gone"}]}}, "bad_request", "unknown target(s) gone"),
            ({"mission": {"robot": "robot9", "steps": [{"dwell": 1}]}}, "unknown_robot", "robot9"),
            ({"mission": {"file": "no-such-file"}}, "bad_request", "no mission file 'no-such-file'"),
        ]
        for change, code, says in bad:
            refused = await ask(ana, {**nightly, **change})
            assert refused["identifier"] == "error" and refused["code"] == code, (change, refused)
            assert says in refused["message"] and refused["message"].startswith("schedule/add: "), refused
        forbidden = await ask(viewer, nightly)
        assert forbidden["identifier"] == "error" and forbidden["code"] == "forbidden", forbidden
        assert await _read(tmp_path, lambda s: s.schedules()) == [] and listed_schedules(ana) == {}

        added = await ask(ana, nightly)
        assert added["identifier"] == "ack", added
        shown = await schedule_state(viewer, "nightly", lambda s: s["state"] == "scheduled")
        assert shown["next_run"] == start and shown["last_run"] is None and shown["on_busy"] == "wait"
        again = await ask(ana, nightly)
        assert again["identifier"] == "error" and "exists already" in again["message"], again

        # The first run: a mission like any other, owned by the schedule.
        clock.now = start + 1.0
        shown = await schedule_state(ana, "nightly", lambda s: s["state"] == "running")
        assert shown["last_run"]["outcome"] == "started" and shown["last_run"]["slot"] == start
        mission_id = shown["last_run"]["mission"]
        # The mission's own message may come after the schedules message (the runner announces it from its task).
        mission = await ana.wait_for(lambda m: m["identifier"] == "mission" and m["id"] == mission_id, WAIT)
        assert (mission["owner"], mission["robot"], mission["name"]) == ("schedule nightly", "robot1", "rounds")

        # An estop holds it (paused): the run's pause is an alert.
        assert (await ask(ana, {"identifier": "estop", "robot": "robot1"}))["identifier"] == "ack"
        paused = await ana.wait_for(lambda m: m["identifier"] == "alert" and m["kind"] == "schedule_failed", WAIT)
        assert paused["subject"] == mission_id and "paused" in paused["text"] and "nightly" in paused["text"], paused
        aborted = await ask(ana, {"identifier": "mission/abort", "mission": mission_id})
        assert aborted["identifier"] == "ack", aborted

        # The next run finds robot1 estopped: it waits within its window, saying why...
        clock.now = start + 3601.0
        waiting = await schedule_state(ana, "nightly", lambda s: s["state"] == "waiting")
        assert "robot1 is emergency-stopped" in waiting["reason"] and waiting["next_run"] == start + 3600
        # ... and when the window (here: the next slot) passes, it is missed, and that is an alert.
        clock.now = start + 7201.0
        missed = await ana.wait_for(lambda m: m["identifier"] == "alert" and m["kind"] == "schedule_missed", WAIT)
        assert "Schedule nightly missed 1 run" in missed["text"] and "emergency-stopped" in missed["text"], missed
        await schedule_state(ana, "nightly", lambda s: (s["last_run"] or {}).get("outcome") == "missed")

        # With on_busy skip, the run due now is skipped, saying so.
        changed = await ask(ana, {"identifier": "schedule/update", "schedule": "nightly", "on_busy": "skip"})
        assert changed["identifier"] == "ack", changed
        skipped = await schedule_state(ana, "nightly", lambda s: (s["last_run"] or {}).get("outcome") == "skipped")
        assert skipped["last_run"]["slot"] == start + 7200 and "emergency-stopped" in skipped["last_run"]["reason"]
        bad_update = await ask(ana, {"identifier": "schedule/update", "schedule": "nightly", "repeat": 30})
        assert bad_update["identifier"] == "error" and "repeat must be at least 60 s" in bad_update["message"]
        kept = await _read(tmp_path, lambda s: s.schedule("nightly"))
        assert kept is not None and kept.repeat == 3600 and kept.on_busy == "skip"

        # After the reset the next run starts.
        reset = await ask(ana, {"identifier": "estop", "robot": "robot1", "action": "reset"})
        assert reset["identifier"] == "ack", reset
        clock.now = start + 3 * 3600 + 1.0
        shown = await schedule_state(ana, "nightly", lambda s: (s["last_run"] or {}).get("slot") == start + 3 * 3600)
        assert shown["last_run"]["outcome"] == "started" and shown["last_run"]["mission"] != mission_id
        outcomes = [(r.slot - start, r.outcome) for r in await _runs(tmp_path, "nightly", 4)]
        assert outcomes == [(0, "started"), (3600, "missed"), (7200, "skipped"), (10800, "started")]

        # Removed: gone for every client and from the database; an unknown one is refused.
        removed = await ask(ana, {"identifier": "schedule/remove", "schedule": "nightly"})
        assert removed["identifier"] == "ack", removed
        await viewer.wait_for(lambda m: m["identifier"] == "schedules" and m["schedules"] == [], WAIT)
        assert await _read(tmp_path, lambda s: (s.schedules(), s.schedule_runs("nightly"))) == ([], [])
        unknown = await ask(ana, {"identifier": "schedule/remove", "schedule": "nightly"})
        assert unknown["identifier"] == "error" and "no schedule 'nightly'" in unknown["message"], unknown
    finally:
        await running.runner.cleanup()


async def test_runs_missed_while_the_relay_was_down_are_recorded_and_alerted_never_started_late(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    clock = HandClock(time.time())
    start = clock.now + 60.0
    running = await schedule_relay(fleet_config, tmp_path, clock)
    try:
        ana = await operator(running)
        hourly = {
            "identifier": "schedule/add", "schedule": "hourly", "start": start, "repeat": 3600,
            "windows": EVERY_DAY, "mission": {"robot": "robot2", "steps": [{"dwell": 1}]}, "priority": 3,
        }  # fmt: skip
        added = await ask(ana, hourly)
        assert added["identifier"] == "ack", added
    finally:
        await running.runner.cleanup()

    # Down for three slots and a bit: those three are missed; the fourth is inside its time and starts.
    clock.now = start + 3 * 3600 + 10.0
    running = await schedule_relay(fleet_config, tmp_path, clock)
    try:
        ana = await operator(running)
        missed = await ana.wait_for(lambda m: m["identifier"] == "alert" and m["kind"] == "schedule_missed", WAIT)
        assert missed["subject"] == "hourly" and missed["robot"] == "robot2", missed
        assert "missed 3 runs" in missed["text"] and "the relay was not running" in missed["text"], missed
        shown = await schedule_state(ana, "hourly", lambda s: (s["last_run"] or {}).get("outcome") == "started")
        assert shown["last_run"]["slot"] == start + 3 * 3600 and shown["priority"] == 3
        runs = [(r.slot - start, r.outcome, r.reason) for r in await _runs(tmp_path, "hourly", 4)]
        assert runs == [
            (0, "missed", "the relay was not running"),
            (3600, "missed", "the relay was not running"),
            (7200, "missed", "the relay was not running"),
            (10800, "started", ""),
        ]
        assert len(_alerts(ana, "schedule_missed")) == 1
    finally:
        await running.runner.cleanup()


async def test_runs_due_together_start_by_priority_and_the_other_is_skipped_saying_why(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    clock = HandClock(time.time())
    start = clock.now + 120.0
    running = await schedule_relay(fleet_config, tmp_path, clock)
    try:
        ana = await operator(running)
        for name, priority in (("low", 1), ("high", 5)):
            schedule = {
                "identifier": "schedule/add", "schedule": name, "start": start, "repeat": 3600, "windows": EVERY_DAY,
                "mission": {"robot": "robot2", "steps": [{"dwell": 60}]}, "priority": priority, "on_busy": "skip",
            }  # fmt: skip
            made = await ask(ana, schedule)
            assert made["identifier"] == "ack", made
        clock.now = start + 1.0
        high = await schedule_state(ana, "high", lambda s: (s["last_run"] or {}).get("outcome") == "started")
        low = await schedule_state(ana, "low", lambda s: (s["last_run"] or {}).get("outcome") == "skipped")
        assert f"robot2 is on mission {high['last_run']['mission']}" in low["last_run"]["reason"], low
    finally:
        await running.runner.cleanup()


async def test_a_run_that_cannot_start_is_recorded_failed_and_alerted(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    folder = tmp_path / "missions"
    folder.mkdir()
    (folder / "round.yaml").write_text("name: Round\nrobots: [{robot: robot1, steps: [{dwell: 1}]}]\n")
    clock = HandClock(time.time())
    start = clock.now + 120.0
    running = await schedule_relay(fleet_config, tmp_path, clock, folder)
    try:
        ana = await operator(running)
        schedule = {
            "identifier": "schedule/add", "schedule": "round", "start": start, "repeat": 3600, "windows": EVERY_DAY,
            "mission": {"file": "round"},
        }  # fmt: skip
        assert (await ask(ana, schedule))["identifier"] == "ack"
        (folder / "round.yaml").unlink()  # the file goes after the schedule was made
        clock.now = start + 1.0
        failed = await ana.wait_for(lambda m: m["identifier"] == "alert" and m["kind"] == "schedule_failed", WAIT)
        assert failed["subject"] == "round" and "could not start" in failed["text"], failed
        assert "no mission file 'round'" in failed["text"], failed
        shown = await schedule_state(ana, "round", lambda s: (s["last_run"] or {}).get("outcome") == "failed")
        assert shown["next_run"] == start + 3600 and "no mission file 'round'" in shown["last_run"]["reason"]
    finally:
        await running.runner.cleanup()
