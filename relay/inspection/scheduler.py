"""The scheduler: each schedule's runs started at their time, as missions like any other, and what became of them.

- **A run** is started through ``mission/start``'s own path (relay.inspection.mission_commands: leases, the estop
  latch, recordings refused, every step checked) as the operator ``schedule <name>``, which owns the mission.
- **A busy robot** (offline, emergency-stopped, on a mission, held by an operator): a schedule with ``on_busy: wait``
  tries again each beat until its run's deadline (relay.inspection.schedule_rules), then records it missed; with
  ``skip`` the run is recorded skipped, saying why. Either way the schedule's state says so to every client.
- **Missed while the relay was down**: at start-up every run whose deadline passed is recorded missed (never started
  late) and raises one ``schedule_missed`` alert per schedule; a run still inside its window starts.
- **Failed**: a run whose start is refused for another reason (a target that no longer exists, no path) is recorded
  failed, and a run's mission that pauses (a goal that failed, an estop's hold, a take-over) raises a
  ``schedule_failed`` alert; an aborted mission raises ``mission_aborted`` already (relay.inspection.mission_commands).

One task, a beat a second (``period``), bounded work a beat (at most ``MAX_SCHEDULES``). Nothing of an estop awaits
it: an estop reaches the robots through relay.control, and the scheduler only learns of it at its next beat. Times
come from the clocks passed in (``wall_clock`` for the schedules, ``clock`` for leases), so tests move them by hand.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime, tzinfo
from typing import TYPE_CHECKING, Final

from ..errors import ProtocolError
from ..session.protocol import ErrorCode, Role
from .messages import ScheduleState, ScheduleStateName, schedules_message
from .records import MissionRecord, ScheduleOutcome, ScheduleRecord, ScheduleRun, new_id
from .schedule_rules import Blackout, Timing, Window, next_run, pending
from .wire import MissionStart
from .write_behind import WriteBehind

if TYPE_CHECKING:
    from ..session.clients import Actor
    from ..station.outbox import Outbox
    from .captures import RaiseAlert
    from .storage import Storage
    from .store import Store

logger = logging.getLogger(__name__)

#: Most schedules a relay keeps (each is a row of the ``schedules`` message every client gets).
MAX_SCHEDULES: Final = 100
#: Runs a new or changed schedule owes from before it was made: none older than this (seconds), so a schedule
#: whose start is "now" in the operator's browser still runs its first round when the command arrives a bit later.
GRACE: Final = 60.0
#: How often a running relay reads the database's schedules again (seconds): a change made with ``xr-relay schedule``
#: reaches it within this. One query of at most MAX_SCHEDULES rows on the store's thread.
REREAD: Final = 5.0
#: Refusals that mean the robot is busy (wait or skip), not that the mission is wrong (failed).
_BUSY_CODES: Final = (ErrorCode.ESTOPPED, ErrorCode.LEASED, ErrorCode.BUSY)

Start = Callable[["Actor", MissionStart, float], Awaitable[list[str]]]
#: Why the robots a mission needs cannot take it now (offline, estopped, busy), or None.
Busy = Callable[[ScheduleRecord, float], "str | None"]


@dataclass(frozen=True, slots=True)
class ScheduleActor:
    """The operator a schedule's runs act as: ``schedule <name>`` in leases, mission owners and logs."""

    client_id: str
    role: Role = "operator"


def owed_after(record: ScheduleRecord, last: ScheduleRun | None) -> float:
    """The time after which ``record`` owes runs: its last run handled, or (none yet) ``GRACE`` before it was made or
    changed. The relay and ``xr-relay schedule`` both say the next run from it."""
    return record.updated - GRACE if last is None else max(record.updated - GRACE, last.slot)


def timing_of(record: ScheduleRecord) -> Timing:
    windows = tuple(Window(tuple(days), first, last) for days, first, last in record.windows)
    return Timing(record.start, record.repeat, windows, tuple(Blackout(a, b) for a, b in record.blackouts))


@dataclass
class _Schedule:
    record: ScheduleRecord
    timing: Timing
    after: float  # the last slot handled (started, skipped, missed or failed)
    last: ScheduleRun | None = None
    waiting: str | None = None  # why the due run waits
    missions: tuple[str, ...] = ()  # the last run's missions
    seen: dict[str, str] = field(default_factory=dict)  # mission -> its state at the last beat
    upcoming: tuple[float, float | None] | None = None  # (after, the next run after it): computed once per ``after``

    def next_run(self, tz: tzinfo) -> float | None:
        """The first run after ``after``. Cached: a beat with nothing due costs a comparison, not a search (a
        narrow window with a drifting repeat takes a few ms to search, and a relay keeps up to 100 schedules)."""
        if self.upcoming is None or self.upcoming[0] != self.after:
            self.upcoming = (self.after, next_run(self.timing, self.after, tz, strictly=True))
        return self.upcoming[1]


class Scheduler:
    def __init__(
        self,
        *,
        start: Start,
        busy: Busy,
        mission: Callable[[str], MissionRecord | None],
        storage: Storage,
        outbox: Outbox,
        alert: RaiseAlert,
        clock: Callable[[], float],
        wall_clock: Callable[[], float] = time.time,
        tz: tzinfo | None = None,
        period: float = 1.0,
        reread: float = REREAD,
    ) -> None:
        """``start``: mission/start's path; ``busy``: why a schedule's robots cannot run it now; ``mission``: a
        mission's record by id; ``tz``: the zone of the windows (None: the relay's local zone); ``reread``: how
        often the database's schedules are read again (seconds)."""
        self._start, self._busy, self._mission = start, busy, mission
        self._storage, self._outbox, self._alert = storage, outbox, alert
        self._clock, self._wall, self._period = clock, wall_clock, period
        self._tz: tzinfo = tz or datetime.now().astimezone().tzinfo or UTC
        self._schedules: dict[str, _Schedule] = {}
        self._runs: WriteBehind[ScheduleRun] = WriteBehind(self._save, "schedule runs")
        self._task: asyncio.Task[None] | None = None
        self._store: Store | None = None
        self._reread, self._unread = reread, reread
        self._edits = 0  # schedules put or removed by this relay's commands: a reading older than one is stale

    @property
    def tz(self) -> tzinfo:
        return self._tz

    @property
    def failure(self) -> str | None:
        """Why schedule runs wait to be stored (``/healthz``), or None."""
        return self._runs.failure

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self, store: Store) -> None:
        """The schedules of the database, each taken up after its last run; runs missed while the relay was down
        are recorded and alerted now; then the beat."""
        self._store = store
        records = await self._storage.run(store.schedules)
        last = await self._storage.run(store.last_schedule_runs)
        for record in records[:MAX_SCHEDULES]:
            self._add(record, last.get(record.id))
        self._runs.start()
        await self._beat("the relay was not running")
        self._task = asyncio.ensure_future(self._loop())

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        await self._runs.close()

    async def _loop(self) -> None:
        while True:
            await asyncio.sleep(self._period)
            try:
                self._unread -= self._period
                if self._unread <= 0:
                    self._unread = self._reread
                    await self.reread()
                await self._beat(None)
            except Exception:  # a bug in one beat must not end the schedules: logged, and the next beat comes
                logger.exception("scheduler: a beat failed")

    async def reread(self) -> None:
        """The database's schedules again: ``xr-relay schedule`` writes there while the relay runs. A schedule
        added, changed (its ``updated``) or removed there is taken up here as a client's command would be; a
        reading during which a command of this relay changed a schedule is dropped (the next one decides)."""
        store = self._store
        if store is None:
            return
        edits = self._edits
        records = await self._storage.run(store.schedules)
        if edits != self._edits:
            return
        found = {r.id: r for r in records[:MAX_SCHEDULES]}
        gone = [name for name in self._schedules if name not in found]
        fresh = [
            r for r in found.values() if (held := self._schedules.get(r.id)) is None or held.record.updated != r.updated
        ]
        for name in gone:
            logger.info("schedule %s: removed from the database (xr-relay schedule)", name)
            self._schedules.pop(name)
        for record in fresh:
            logger.info("schedule %s: %s in the database (xr-relay schedule)", record.id,
                        "changed" if record.id in self._schedules else "added")  # fmt: skip
            held = self._schedules.get(record.id)
            self._add(record, None if held is None else held.last)
        if gone or fresh:
            self.announce()

    # -- the schedules ----------------------------------------------------------------------------

    def names(self) -> list[str]:
        return sorted(self._schedules)

    def get(self, name: str) -> ScheduleRecord | None:
        held = self._schedules.get(name)
        return None if held is None else held.record

    def put(self, record: ScheduleRecord) -> None:
        """A schedule added or changed (stored already): runs owed from now on, announced to every client."""
        held = self._schedules.get(record.id)
        self._add(record, None if held is None else held.last)
        self._edits += 1
        self.announce()

    def remove(self, name: str) -> None:
        self._schedules.pop(name, None)
        self._edits += 1
        self.announce()

    def _add(self, record: ScheduleRecord, last: ScheduleRun | None) -> None:
        held = _Schedule(record, timing_of(record), owed_after(record, last), last)
        if last is not None and last.mission:
            held.missions = tuple(last.mission.split(","))
        self._schedules[record.id] = held

    # -- a beat -----------------------------------------------------------------------------------

    async def _beat(self, down: str | None) -> None:
        """Every schedule, the highest priority first: runs missed, the run due, the missions it started."""
        changed = False
        order = sorted(self._schedules.values(), key=lambda s: (-s.record.priority, s.record.id))
        for held in order:
            if self._schedules.get(held.record.id) is not held:
                continue  # removed or changed by a command while an earlier schedule's start was awaited
            changed |= self._follow(held)
            upcoming, now = held.next_run(self._tz), self._wall()
            if upcoming is None or upcoming > now:
                continue  # nothing owed yet
            owed = pending(held.timing, held.after, now, self._tz)
            if owed.missed:
                self._missed(held, owed.missed, owed.more, down or held.waiting or "not started in its window")
                held.after, held.waiting, changed = owed.last_missed or held.after, None, True
            if owed.due is not None:
                changed |= await self._due(held, owed.due)
        if changed or down is not None:
            self.announce()

    async def _due(self, held: _Schedule, slot: float) -> bool:
        record = held.record
        busy = self._busy(record, self._clock())
        if busy is None:
            try:
                missions = await self._start(ScheduleActor(f"schedule {record.id}"), _command(record), self._clock())
            except ProtocolError as exc:  # CommandRejected is one
                if exc.code not in _BUSY_CODES and "on a mission already" not in exc.message:
                    self._record(held, slot, "failed", None, exc.message)
                    self._alert(
                        "schedule_failed",
                        f"Schedule {record.id}: the run of {_when(slot, self._tz)} could not start: {exc.message}",
                        robot=record.mission.get("robot"), subject=record.id,
                    )  # fmt: skip
                    return True
                busy = exc.message
            else:
                # Seen running: a pause before the next beat (an estop a moment later) is still a change.
                held.missions, held.seen = tuple(missions), dict.fromkeys(missions, "running")
                self._record(held, slot, "started", ",".join(missions), "")
                logger.info("schedule %s: run of %s started: %s", record.id, _when(slot, self._tz), missions)
                return True
        if record.on_busy == "skip":
            self._record(held, slot, "skipped", None, busy)
            logger.info("schedule %s: run of %s skipped: %s", record.id, _when(slot, self._tz), busy)
            return True
        changed = busy != held.waiting
        held.waiting = busy
        return changed

    def _follow(self, held: _Schedule) -> bool:
        """A mission of the last run that paused since the last beat raises a ``schedule_failed`` alert."""
        changed = False
        for mission_id in held.missions:
            record = self._mission(mission_id)
            if record is None:
                continue
            before = held.seen.get(mission_id)
            held.seen[mission_id] = record.state
            if record.state != before:
                changed = True
                if record.state == "paused" and before is not None:
                    reason = f": {record.reason}" if record.reason else ""
                    self._alert(
                        "schedule_failed",
                        f"Schedule {held.record.id}: mission {record.name} of {record.robot} paused at step "
                        f"{record.current + 1}{reason}",
                        robot=record.robot, subject=record.id,
                    )  # fmt: skip
        return changed

    def _missed(self, held: _Schedule, slots: Sequence[float], more: int, why: str) -> None:
        for slot in slots:
            self._record(held, slot, "missed", None, why)
        count = f"{len(slots)} run{'s' if len(slots) > 1 else ''}" + (f" and up to {more} more" if more else "")
        span = _when(slots[0], self._tz) + ("" if len(slots) == 1 else f" to {_when(slots[-1], self._tz)}")
        self._alert(
            "schedule_missed",
            f"Schedule {held.record.id} missed {count} ({span}): {why}",
            robot=held.record.mission.get("robot"), subject=held.record.id,
        )  # fmt: skip

    def _record(self, held: _Schedule, slot: float, outcome: ScheduleOutcome, mission: str | None, why: str) -> None:
        run = ScheduleRun(new_id("r", 6), held.record.id, slot, self._wall(), outcome, mission, why[:500])
        held.last, held.after, held.waiting = run, max(held.after, slot), None
        if self._schedules.get(held.record.id) is held:  # not removed while its start was awaited: no orphan row
            self._runs.put(run)

    async def _save(self, run: ScheduleRun) -> None:
        store = self._storage.store
        if store is not None:
            await self._storage.run(lambda: store.add_schedule_run(run))

    # -- what clients see -------------------------------------------------------------------------

    def states(self) -> list[ScheduleState]:
        now = self._wall()
        found = []
        for name in sorted(self._schedules):
            held = self._schedules[name]
            upcoming = held.next_run(self._tz)
            active = any(
                (m := self._mission(mission_id)) is not None and m.state in ("running", "paused")
                for mission_id in held.missions
            )
            state: ScheduleStateName = (
                "waiting" if held.waiting else "running" if active else "scheduled" if upcoming else "over"
            )
            found.append(ScheduleState(held.record, upcoming, held.last, state, held.waiting or "", now))
        return found

    def announce(self) -> None:
        self._outbox.broadcast(schedules_message(self.states()))


def _command(record: ScheduleRecord) -> MissionStart:
    mission = record.mission
    targets = mission.get("targets")
    return MissionStart(
        id=f"schedule-{record.id}",
        file=mission.get("file"),
        robot=mission.get("robot"),
        steps=mission.get("steps"),
        targets=None if targets is None else tuple(targets),
        name=mission.get("name") or record.id,
    )


def _when(t: float, tz: tzinfo | None) -> str:
    return datetime.fromtimestamp(t, tz).strftime("%a %d %b %Y %H:%M")
