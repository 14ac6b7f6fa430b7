"""``xr-relay schedule add|list|remove`` on a real SQLite database (relay/inspection/schedule_cli.py): bad input named
with nothing changed, and a relay started on the database runs what the command line made."""

from __future__ import annotations

import asyncio
import time
from datetime import datetime
from pathlib import Path

import pytest

from relay.cli.main import main
from relay.config import FleetConfig
from relay.inspection.scheduler import REREAD
from relay.inspection.store import Store
from tests.conftest import LOAD_SLACK, ROOT
from tests.helpers.inspection import operator
from tests.helpers.schedules import EVERY_DAY, HandClock, ask, listed_schedules, schedule_relay, schedule_state
from tests.helpers.waiting import wait_until


def _run(tmp_path: Path, *args: str) -> int:
    database = str(tmp_path / "inspection.sqlite")
    site = ["--database", database, "--config", str(ROOT / "robots.yaml"), "--missions", str(ROOT / "missions")]
    return main(["schedule", *site, *args])


def _schedules(tmp_path: Path) -> list[str]:
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "inspection-images") as store:
        return [s.id for s in store.schedules()]


def _local(t: float) -> str:
    return datetime.fromtimestamp(t).isoformat(timespec="seconds")


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--targets", "spill", "--repeat", "3600"], "a schedule needs at least one window"),
        (["--targets", "spill", "--repeat", "30", "--window", "mon-fri", "8-17"], "repeat must be at least 60 s"),
        (["--targets", "spill,gone", "--repeat", "3600", "--window", "mon", "8-17"], "unknown target(s) gone"),
        (["--file", "nope", "--repeat", "3600", "--window", "mon", "8-17"], "no mission file 'nope'"),
        (["--robot", "robot9", "--steps", '[{"dwell": 1}]', "--repeat", "3600", "--window", "mon", "8-17"],
         "unknown robot 'robot9'"),
        (["--targets", "spill", "--repeat", "3600", "--window", "funday", "8-17"], "unknown weekday 'funday'"),
        (["--targets", "spill", "--repeat", "3600", "--window", "mon", "17-8"], "hours must be 0 <= first < last"),
    ],
)  # fmt: skip
def test_bad_input_is_named_and_changes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], says: str
) -> None:
    assert _run(tmp_path, "add", "nightly", "--start", "2026-11-30T08:00", *args) == 2
    err = capsys.readouterr().err
    assert err.startswith("xr-relay schedule: ") and says in err, err
    assert _schedules(tmp_path) == []


async def test_a_schedule_made_on_the_command_line_runs_in_the_relay(
    fleet_config: FleetConfig, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    clock = HandClock(time.time())
    start = float(int(clock.now) + 120)
    made = await asyncio.to_thread(
        _run,
        tmp_path, "add", "rounds", "--robot", "robot3", "--steps", '[{"dwell": 1}]', "--start", _local(start),
        "--repeat", "3600", "--window", "mon-sun", "0-24", "--on-busy", "skip", "--priority", "2",
    )  # fmt: skip
    assert made == 0, capsys.readouterr().err
    assert "added rounds; next run" in capsys.readouterr().out
    twice = ["add", "rounds", "--file", "demo", "--start", _local(start), "--repeat", "60", "--window", "sat", "0-24"]
    assert await asyncio.to_thread(_run, tmp_path, *twice) == 2
    assert "schedule 'rounds' exists already" in capsys.readouterr().err
    assert await asyncio.to_thread(_run, tmp_path, "list") == 0
    listed = capsys.readouterr().out
    assert listed.startswith("rounds\t") and "every 3600 s" in listed and "on busy skip" in listed, listed
    assert "mon,tue,wed,thu,fri,sat,sun 0-24" in listed and "last none" in listed, listed

    running = await schedule_relay(fleet_config, tmp_path, clock)
    try:
        ana = await operator(running)
        shown = await schedule_state(ana, "rounds", lambda s: s["state"] == "scheduled")
        assert shown["next_run"] == start and shown["priority"] == 2 and shown["owner"].startswith("xr-relay schedule")
        clock.now = start + 1.0
        shown = await schedule_state(ana, "rounds", lambda s: (s["last_run"] or {}).get("outcome") == "started")
        assert shown["last_run"]["mission"].endswith(".robot3"), shown
    finally:
        await running.runner.cleanup()

    assert await asyncio.to_thread(_run, tmp_path, "remove", "rounds") == 0
    assert await asyncio.to_thread(_schedules, tmp_path) == []
    assert await asyncio.to_thread(_run, tmp_path, "remove", "rounds") == 2
    assert "no schedule 'rounds'" in capsys.readouterr().err


async def test_a_running_relay_takes_up_what_the_command_line_adds_and_removes(
    fleet_config: FleetConfig, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    clock = HandClock(time.time())
    start = float(int(clock.now) + 3600)
    running = await schedule_relay(fleet_config, tmp_path, clock)
    try:
        ana = await operator(running)
        made = await ask(ana, {
            "identifier": "schedule/add", "schedule": "by-hand", "start": start, "repeat": 3600, "windows": EVERY_DAY,
            "mission": {"targets": ["spill"]},
        })  # fmt: skip
        assert made["identifier"] == "ack", made
        args = ["--robot", "robot3", "--steps", '[{"dwell": 1}]', "--start", _local(start), "--repeat", "3600"]
        added = await asyncio.to_thread(_run, tmp_path, "add", "nightly", *args, "--window", "mon-sun", "0-24")
        assert added == 0, capsys.readouterr().err
        # Within the relay's reading period (REREAD, 5 s), with a loaded machine's margin: no restart.
        shown = await schedule_state(ana, "nightly", lambda s: s["state"] == "scheduled")
        assert shown["next_run"] == start and shown["owner"].startswith("xr-relay schedule")
        assert await asyncio.to_thread(_run, tmp_path, "remove", "nightly") == 0
        await wait_until(lambda: "nightly" not in listed_schedules(ana), REREAD + 10 + LOAD_SLACK, "nightly gone")
        # The schedule made by a client stays as it was: a reading never undoes a command.
        assert listed_schedules(ana)["by-hand"]["state"] == "scheduled"
    finally:
        await running.runner.cleanup()
