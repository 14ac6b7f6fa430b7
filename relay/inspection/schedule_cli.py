"""``xr-relay schedule``: schedules made, listed and removed on the inspection database directly (no relay needed).

    xr-relay schedule add NAME (--file F | --targets A,B | --robot R --steps JSON) --start TIME --repeat SECONDS
                          --window DAYS HOURS [--window ...] [--blackout FROM/TO ...] [--priority N]
                          [--on-busy wait|skip] [--mission-name NAME]
    xr-relay schedule list
    xr-relay schedule remove NAME
    (each with [--database FILE_OR_URL] [--config robots.yaml] [--missions DIR])

``TIME`` is ISO 8601 (``2026-11-30T08:00``: the local time of this machine, or with an offset); ``DAYS`` are weekdays
(``mon-fri``, ``sat,sun``), ``HOURS`` ``first-last`` (``8-17``). The schedule is checked as ``schedule/add`` checks it
(relay.inspection.schedule_commands.refusal: a window, a repeat of at least 60 s, robots of robots.yaml, targets of
the scene and the database, a mission file that exists); a problem is one line naming it, exit status 2, and nothing
changes. A relay on the database reads its schedules when it starts.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .records import ScheduleRecord, ScheduleRun
from .schedule_commands import refusal
from .schedule_rules import WEEKDAYS, ScheduleError, next_run, weekday_numbers
from .scheduler import GRACE, owed_after, timing_of

if TYPE_CHECKING:
    from .store import Store

_PROG = "xr-relay schedule"


class _Refused(Exception):
    """A schedule that cannot be made; the message names why."""


#: The zone of the windows: this machine's, as the relay's scheduler takes it.
_LOCAL = datetime.now().astimezone().tzinfo or UTC


def main(argv: Sequence[str] | None = None) -> int:
    from .store import StoreError

    args = _parser().parse_args(argv)
    try:
        if "://" not in args.database and not Path(args.database).is_file() and args.action != "add":
            raise _Refused(f"{args.database}: no such database (start the relay with --database, or name it here)")
        with _open(args.database) as store:
            if args.action == "add":
                record = _record(args)
                _check(record, store, args)
                if not store.add_schedule(record):
                    raise _Refused(f"schedule {record.id!r} exists already")
                print(f"{_PROG}: added {record.id}; next run {_when(_next(record))}")  # noqa: T201
            elif args.action == "remove":
                if not store.remove_schedule(args.name):
                    raise _Refused(f"no schedule {args.name!r}")
                print(f"{_PROG}: removed {args.name}")  # noqa: T201
            else:
                last = store.last_schedule_runs()
                for record in store.schedules():
                    run = last.get(record.id)
                    done = "none" if run is None else f"{run.outcome} ({_when(run.slot)}) {run.reason}".rstrip()
                    print(  # noqa: T201
                        f"{record.id}\t{json.dumps(record.mission)}\tevery {record.repeat:g} s\t"
                        f"{_windows(record)}\tpriority {record.priority}\ton busy {record.on_busy}\t"
                        f"next {_when(_next(record, run))}\tlast {done}"
                    )
    except (_Refused, StoreError, OSError) as exc:
        print(f"{_PROG}: {exc}", file=sys.stderr)  # noqa: T201
        return 2
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=_PROG, description="Missions started at times (docs/inspection.md).")
    parser.add_argument("--database", default="xr-relay-inspection.sqlite", help="SQLite file or postgresql:// URL")
    parser.add_argument("--config", type=Path, default=Path("robots.yaml"), help="the fleet: robots and the scene")
    parser.add_argument("--missions", type=Path, default=Path("missions"), help="the relay's mission files")
    actions = parser.add_subparsers(dest="action", required=True)
    add = actions.add_parser("add", help="make a schedule")
    add.add_argument("name", help="1-64 letters, digits, _ or -")
    what = add.add_mutually_exclusive_group(required=True)
    what.add_argument("--file", help="a mission file of the missions directory, by name (demo)")
    what.add_argument("--targets", help="target ids for the fleet, comma-separated")
    what.add_argument("--steps", help='with --robot: steps as JSON, [{"inspect": "spill"}, {"dwell": 2}]')
    add.add_argument("--robot", help="the robot of --steps")
    add.add_argument("--mission-name", help="the missions' name (default: the schedule's)")
    add.add_argument("--start", required=True, help="the first run: ISO 8601, local time unless an offset is given")
    add.add_argument("--repeat", type=float, required=True, help="seconds between runs (at least 60)")
    add.add_argument(
        "--window",
        nargs=2,
        action="append",
        metavar=("DAYS", "HOURS"),
        default=[],
        help="weekdays (mon-fri, sat,sun) and hours first-last (8-17) of local time; repeatable",
    )
    add.add_argument("--blackout", action="append", default=[], metavar="FROM/TO", help="no run in [FROM, TO)")
    add.add_argument("--priority", type=int, default=0, help="higher first when runs are due together")
    add.add_argument("--on-busy", choices=("wait", "skip"), default="wait", help="when the robot is busy")
    remove = actions.add_parser("remove", help="remove a schedule and the record of its runs")
    remove.add_argument("name")
    actions.add_parser("list", help="every schedule, with its next and last run")
    return parser


def _open(database: str) -> Store:
    from .store import Store, default_images

    return Store.open(database, default_images(database))


def _record(args: argparse.Namespace) -> ScheduleRecord:
    from .records import TARGET_ID

    if not TARGET_ID.match(args.name):
        raise _Refused(f"schedule name {args.name[:80]!r} must be 1-64 letters, digits, _ or -")
    mission: dict[str, Any]
    if args.file is not None:
        mission = {"file": args.file}
    elif args.targets is not None:
        mission = {"targets": [t.strip() for t in args.targets.split(",") if t.strip()]}
    else:
        if args.robot is None:
            raise _Refused("--steps needs --robot")
        try:
            mission = {"robot": args.robot, "steps": json.loads(args.steps)}
        except json.JSONDecodeError as exc:
            raise _Refused(f"--steps is not JSON: {exc}") from None
    if args.mission_name:
        mission["name"] = args.mission_name
    windows = tuple(_window(days, hours) for days, hours in args.window)
    blackouts = tuple(_blackout(text) for text in args.blackout)
    now = time.time()
    return ScheduleRecord(
        args.name, mission, _time(args.start, "--start"), args.repeat, windows, blackouts, args.priority,
        args.on_busy, now, now, f"xr-relay schedule ({_user()})",
    )  # fmt: skip


def _check(record: ScheduleRecord, store: Store, args: argparse.Namespace) -> None:
    """The checks of ``schedule/add``, with what this machine knows of the site: robots.yaml, the database."""
    from ..config import load_config
    from ..errors import ConfigError
    from .missions import MissionError, steps_from_wire

    try:
        config = load_config(args.config)
    except ConfigError as exc:
        raise _Refused(f"cannot check the schedule's robots and targets: {exc}") from None
    targets = {t.id for t in store.targets()} | _scene_targets(config)
    found = refusal(record, config.names, targets)
    if found is not None:
        raise _Refused(found[1])
    if record.mission.get("steps") is not None:
        try:
            steps_from_wire(record.mission["steps"], "--steps")
        except MissionError as exc:
            raise _Refused(str(exc)) from None
    file = record.mission.get("file")
    if file is not None and not any((args.missions / f"{file}{s}").is_file() for s in (".yaml", ".kmz", ".kml")):
        raise _Refused(f"no mission file {file!r} in {args.missions}")


def _scene_targets(config: Any) -> set[str]:
    """The targets the scene's hazards make (relay.inspection.targets.facility_targets), as the relay loads them."""
    from ..twin.facility import load_facility
    from .targets import facility_targets

    if config.sim.world is None:
        return set()
    return {t.id for t in facility_targets(load_facility(config.sim.world))}


def _window(days: str, hours: str) -> tuple[tuple[int, ...], int, int]:
    try:
        found: list[int] = []
        for part in days.split(","):
            first, _, last = part.partition("-")
            a = weekday_numbers([first])[0]
            b = weekday_numbers([last])[0] if last else a
            found += range(a, b + 1) if a <= b else [*range(a, 7), *range(0, b + 1)]
        low, _, high = hours.partition("-")
        return tuple(sorted(set(found))), int(low), int(high)
    except (ScheduleError, ValueError) as exc:
        raise _Refused(f"--window {days} {hours}: days like mon-fri or sat,sun, hours like 8-17 ({exc})") from None


def _blackout(text: str) -> tuple[float, float]:
    start, _, end = text.partition("/")
    if not end:
        raise _Refused(f"--blackout {text!r}: FROM/TO, two ISO 8601 times")
    return _time(start, "--blackout"), _time(end, "--blackout")


def _time(text: str, option: str) -> float:
    try:
        return datetime.fromisoformat(text).timestamp()  # naive: this machine's local time
    except ValueError:
        raise _Refused(f"{option} {text!r} is not an ISO 8601 time (2026-11-30T08:00)") from None


def _next(record: ScheduleRecord, last: ScheduleRun | None = None) -> float | None:
    """The next run as the relay's scheduler counts it (owed_after): a start less than its grace in the past still
    runs when a relay takes the schedule up; older ones it records missed."""
    after = max(owed_after(record, last), time.time() - GRACE)
    try:
        return next_run(timing_of(record), after, _LOCAL, strictly=True)
    except ScheduleError:
        return None


def _windows(record: ScheduleRecord) -> str:
    return " ".join(f"{','.join(WEEKDAYS[d] for d in days)} {first}-{last}" for days, first, last in record.windows)


def _when(t: float | None) -> str:
    return "none" if t is None else datetime.fromtimestamp(t).astimezone().strftime("%a %d %b %Y %H:%M %Z")


def _user() -> str:
    import getpass

    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return "unknown"
