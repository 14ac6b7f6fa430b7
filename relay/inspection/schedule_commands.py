"""``schedule/add``, ``schedule/update`` and ``schedule/remove``: every rule checked against the schedule as it would
be, then stored, then the scheduler told (relay.inspection.scheduler) and every client sent ``schedules``.

Bad input (no window, a repeat under 60 s, a target or robot that does not exist, a mission file that is not there,
steps that do not parse) is a ``bad_request`` (``unknown_robot`` for a robot) naming it, and nothing changes. The
same check serves ``xr-relay schedule add`` (relay.inspection.schedule_cli), which has no relay to ask.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from ..errors import CommandRejected
from ..session.protocol import ErrorCode
from .records import ScheduleRecord
from .schedule_rules import ScheduleError, check
from .scheduler import MAX_SCHEDULES, Scheduler, timing_of
from .wire import MissionStart, ScheduleChange, ScheduleRemove

if TYPE_CHECKING:
    from ..session.clients import Client
    from ..wire.fields import RequestId
    from .planning import MissionPlanning
    from .storage import Storage


def schedule_from(command: ScheduleChange, before: ScheduleRecord | None, owner: str, now: float) -> ScheduleRecord:
    """The schedule a command makes (``before``: the one it changes, None for ``schedule/add``)."""
    if before is None:
        assert command.mission is not None and command.start is not None and command.repeat is not None
        assert command.windows is not None
        return ScheduleRecord(
            command.schedule, command.mission, command.start, command.repeat, command.windows,
            command.blackouts or (), command.priority or 0, command.on_busy or "wait", now, now, owner,
        )  # fmt: skip
    changes: dict[str, Any] = {
        k: getattr(command, k)
        for k in ("mission", "start", "repeat", "windows", "blackouts", "priority", "on_busy")
        if getattr(command, k) is not None
    }
    return replace(before, **changes, updated=now, owner=owner)


def refusal(record: ScheduleRecord, robots: Collection[str], targets: Collection[str]) -> tuple[str, str] | None:
    """What is wrong with a schedule without reading files: (error code, why), or None. The timing's rules
    (relay.inspection.schedule_rules.check), a mission's robot and its targets (of ``targets`` or its steps)."""
    try:
        check(timing_of(record))
    except ScheduleError as exc:
        return ErrorCode.BAD_REQUEST, str(exc)
    mission = record.mission
    robot = mission.get("robot")
    if robot is not None and robot not in robots:
        return ErrorCode.UNKNOWN_ROBOT, f"unknown robot {robot!r}"
    named = list(mission.get("targets") or [])
    for step in mission.get("steps") or []:
        if isinstance(step, dict):
            named += [v for k, v in step.items() if k in ("inspect", "capture") and isinstance(v, str)]
    unknown = sorted({t for t in named if t not in targets})
    if unknown:
        return ErrorCode.BAD_REQUEST, f"unknown target(s) {', '.join(t[:64] for t in unknown[:5])}"
    return None


class ScheduleCommands:
    def __init__(
        self,
        robots: Collection[str],
        *,
        targets: Mapping[str, object],
        planning: MissionPlanning,
        storage: Storage,
        scheduler: Scheduler,
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        self._robots, self._targets, self._planning = robots, targets, planning
        self._storage, self._scheduler, self._wall = storage, scheduler, wall_clock

    async def change(self, client: Client, command: ScheduleChange) -> None:
        where, name = f"schedule/{command.action}", command.schedule
        before = self._scheduler.get(name)
        if command.action == "add" and before is not None:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"{where}: schedule {name!r} exists already", command.id)
        if command.action == "update" and before is None:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"{where}: no schedule {name[:80]!r}", command.id)
        if before is None and len(self._scheduler.names()) >= MAX_SCHEDULES:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"{where}: at most {MAX_SCHEDULES} schedules", command.id)
        record = schedule_from(command, before, client.name or client.client_id, self._wall())
        await self._check(record, where, command.id)
        if before is None:
            if not await self._storage.call(lambda s: s.add_schedule(record), command.id):
                raise CommandRejected(ErrorCode.BAD_REQUEST, f"{where}: schedule {name!r} exists already", command.id)
        else:
            await self._storage.call(lambda s: s.save_schedule(record), command.id)
        self._scheduler.put(record)

    async def remove(self, command: ScheduleRemove) -> None:
        name = command.schedule
        if not await self._storage.call(lambda s: s.remove_schedule(name), command.id):
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"schedule/remove: no schedule {name[:80]!r}", command.id)
        self._scheduler.remove(name)

    async def _check(self, record: ScheduleRecord, where: str, request_id: RequestId) -> None:
        """Every rule, and the mission read as ``mission/start`` reads it (a file, steps), changing nothing."""
        found = refusal(record, self._robots, self._targets)
        if found is not None:
            raise CommandRejected(found[0], f"{where}: {found[1]}", request_id)
        mission = record.mission
        trial = MissionStart(
            id=request_id, file=mission.get("file"), robot=mission.get("robot"), steps=mission.get("steps"),
            targets=None if mission.get("targets") is None else tuple(mission["targets"]), name=mission.get("name"),
        )  # fmt: skip
        try:
            plan, placemarks = await self._planning.plan(trial)
        except CommandRejected as exc:
            raise CommandRejected(exc.code, exc.message.replace("mission/start", where), request_id) from None
        known = set(self._targets) | {t.id for t in placemarks}
        named = set(plan.targets) | {s.target for _, steps in plan.robots for s in steps if s.target is not None}
        unknown = sorted(named - known)
        if unknown:
            raise CommandRejected(
                ErrorCode.BAD_REQUEST,
                f"{where}: unknown target(s) {', '.join(t[:64] for t in unknown[:5])}",
                request_id,
            )
        robots = sorted({robot for robot, _ in plan.robots} - set(self._robots))
        if robots:
            raise CommandRejected(ErrorCode.UNKNOWN_ROBOT, f"{where}: unknown robot(s) {', '.join(robots)}", request_id)
