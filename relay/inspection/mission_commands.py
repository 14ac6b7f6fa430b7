"""``mission/start`` and ``mission/control`` under the rules every command obeys (role, lease, estop latch,
recordings), and what a running mission asks of the relay: go, stop, announce its record (an aborted mission
raises an alert, relay.inspection.alerts), give its lease back."""

from __future__ import annotations

import logging
import time
from collections.abc import Awaitable, Callable, Mapping
from typing import TYPE_CHECKING

from ..errors import CommandRejected
from ..session.protocol import ErrorCode
from .messages import mission_message
from .records import MissionRecord, Step, new_id
from .runner import MissionRunner, holder
from .target_book import TargetBook
from .wire import MissionControl, MissionStart
from .write_behind import WriteBehind

if TYPE_CHECKING:
    from ..backends.base import Backend
    from ..config import Robot
    from ..control.control import Control
    from ..fleet.state import FleetState
    from ..session.clients import Actor, Client
    from ..station.outbox import Outbox
    from .captures import RaiseAlert
    from .planning import MissionPlanning, Position
    from .storage import Storage
    from .store import Store

logger = logging.getLogger(__name__)


class MissionCommands:
    """Starts and controls missions; its :class:`~relay.inspection.runner.MissionRunner` carries them out."""

    def __init__(
        self,
        robots: Mapping[str, Robot],
        *,
        backend: Backend,
        control: Control,
        fleet: FleetState,
        outbox: Outbox,
        book: TargetBook,
        planning: MissionPlanning,
        storage: Storage,
        records: WriteBehind[MissionRecord],
        capture: Callable[[MissionRecord, Step], Awaitable[None]],
        alert: RaiseAlert,
        clock: Callable[[], float],
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        self._robots = robots
        self._backend, self._control, self._fleet, self._outbox = backend, control, fleet, outbox
        self._book, self._planning, self._storage, self._records = book, planning, storage, records
        self._clock, self._wall, self._alert = clock, wall_clock, alert
        self.runner = MissionRunner(
            go=self._go, stop=self._stop, capture=capture, publish=self._publish, release=self._release,
            wall_clock=wall_clock,
        )  # fmt: skip

    async def start(self, client: Actor, command: MissionStart, now: float) -> list[str]:
        """Start the mission (every rule checked first: CommandRejected naming what refused it); its records' ids.
        ``client``: who starts it (a client, or a schedule, relay.inspection.scheduler)."""
        plan, placemarks = await self._planning.plan(command)
        if placemarks:
            await self._book.add(placemarks, f"mission/start: {command.file}", command.id)
        targets = self._book.targets
        robots: dict[str, tuple[Step, ...]]
        if plan.targets:
            unknown = [t for t in plan.targets if t not in targets]
            if unknown:
                # Named, a few of them: the site's targets are in the `targets` list every client holds.
                more = f" and {len(unknown) - 5} more" if len(unknown) > 5 else ""
                raise CommandRejected(
                    ErrorCode.BAD_REQUEST,
                    f"mission/start: unknown target(s) {', '.join(t[:64] for t in unknown[:5])}{more}; "
                    f"the site has {len(targets)} targets (the `targets` list)",
                    command.id,
                )
            among = command.robots if command.robots is not None else self._robots  # a team's or a room's, or all
            free = {r: self._position(r) for r in among if self._free(client, r, now)}
            positions = {r: p for r, p in free.items() if p is not None}
            robots = await self._planning.assign(plan.targets, positions, command.id)
        else:
            robots = dict(plan.robots)
        for robot in robots:
            if robot not in self._robots:
                raise CommandRejected(ErrorCode.UNKNOWN_ROBOT, f"mission/start: unknown robot {robot!r}", command.id)
            self._control.gate.require_commandable(
                client, robot, f"mission/start {robot}", command.id, now, moves=True, permission="inspect"
            )
            if self.runner.active(robot) is not None:
                raise CommandRejected(
                    ErrorCode.BAD_REQUEST, f"mission/start: {robot} is on a mission already", command.id
                )
        # Every step of every robot is checked before any robot moves.
        waypoints = await self._planning.check(robots, self._starts(robots), "mission/start", command.id)
        group = new_id("m")
        wall = self._wall()
        records = [
            MissionRecord(f"{group}.{robot}", plan.name, robot, steps, "pending", 0, "", wall, wall, client.client_id)
            for robot, steps in robots.items()
        ]
        for record in records:  # all stored before any robot moves: a full or locked database starts none
            await self._storage.call(_saver(record), command.id)
        for record in records:
            robot = record.robot
            previous = self._control.leases.holder(robot)
            self._control.leases.take(robot, holder(record.id), now)
            self._control.lease_changed(robot, holder(record.id), previous, "acquired", now)
            self.runner.start(record, waypoints[robot])
            logger.info("mission %s started by %s: %s, %d steps", record.id, client.client_id, robot, len(record.steps))
        return [record.id for record in records]

    def busy(self, robot: str | None, now: float) -> str | None:
        """Why ``robot`` (None: every robot of the fleet) cannot take a mission now, or None when it (one of them)
        can: offline, emergency-stopped, on a mission, held by an operator, a recording. A schedule's run waits or is
        skipped for it (relay.inspection.scheduler)."""
        names = [robot] if robot is not None else list(self._robots)
        reasons = [self._busy_reason(name, now) for name in names if name in self._robots]
        return "; ".join(reasons)[:300] if reasons and all(reasons) else None

    def _busy_reason(self, robot: str, now: float) -> str:
        if not self._fleet.online(robot, now):
            return f"{robot} is offline"
        if robot in self._control.latched:
            return f"{robot} is emergency-stopped"
        run = self.runner.active(robot)
        if run is not None:
            return f"{robot} is on mission {run.record.id} ({run.record.state})"
        lease = self._control.leases.holder(robot)
        if lease is not None:
            return f"{robot} is controlled by {lease}"
        return self._backend.command_refusal(robot) or ""

    def _free(self, client: Actor, robot: str, now: float) -> bool:
        holder_now = self._control.leases.holder(robot)
        return (
            self._fleet.online(robot, now)
            and robot not in self._control.latched
            and self.runner.active(robot) is None
            and holder_now in (None, client.client_id)
            and self._backend.command_refusal(robot) is None
        )

    def _position(self, robot: str) -> Position | None:
        pose = self._fleet.snapshot(self._clock())[robot]["pose"]
        return None if pose is None else (pose["x"], pose["y"])

    def _starts(self, robots: Mapping[str, object]) -> dict[str, Position]:
        """Where each robot stands, or its initial pose while none is known: where its steps are checked from."""
        return {
            r: self._position(r) or (self._robots[r].initial_pose.x, self._robots[r].initial_pose.y) for r in robots
        }

    async def control(self, client: Client, command: MissionControl, now: float) -> None:
        run = self.runner.runs.get(command.mission)
        if run is None:
            raise CommandRejected(
                ErrorCode.BAD_REQUEST, f"mission/{command.action}: no mission {command.mission[:80]!r}", command.id
            )
        if run.record.state in ("done", "aborted"):
            raise CommandRejected(
                ErrorCode.BAD_REQUEST,
                f"mission/{command.action}: mission {run.record.id} has ended ({run.record.state})",
                command.id,
            )
        robot = run.record.robot
        lease = self._control.leases.holder(robot)
        # A mission restored after a restart holds no lease (leases live in memory): free is as good as its own.
        if lease not in (None, holder(run.record.id), client.client_id):
            raise CommandRejected(
                ErrorCode.LEASED, f"mission/{command.action}: {robot} is controlled by {lease}", command.id
            )
        revive = None
        if command.action == "resume":
            if lease == holder(run.record.id):  # held by the mission itself (an estop held it): the other rules
                self._control.gate.require_movable(client, robot, "mission/resume", command.id, permission="inspect")
            else:
                self._control.gate.require_commandable(
                    client, robot, "mission/resume", command.id, now, moves=True, permission="inspect"
                )
            if self.runner.needs_task(run):  # restored: the rest is planned again from where the robot stands
                rest = {robot: run.record.steps}
                revive = (await self._planning.check(rest, self._starts(rest), "mission/resume", command.id))[robot]
            if lease != holder(run.record.id):  # an operator who took over hands the robot back to the mission
                self._control.leases.take(robot, holder(run.record.id), now)
                self._control.lease_changed(robot, holder(run.record.id), lease, "acquired", now)
        if revive is not None:
            self.runner.revive(run, revive)
            return
        try:
            await self.runner.act(run, command.action, client.client_id)
        except ValueError as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"mission/{command.action}: {exc}", command.id) from None

    # -- what the runner asks of the relay --------------------------------------------------------

    async def _go(self, robot: str, x: float, y: float, yaw: float | None) -> None:
        generation = self._control.supersede(robot)
        self._fleet.set_teleop(robot, False)
        await self._backend.send_goal(robot, x, y, yaw, current=lambda: self._control.generation(robot) == generation)

    async def _stop(self, robot: str) -> None:
        self._control.supersede(robot)
        await self._backend.stop_robot(robot)

    def _publish(self, record: MissionRecord) -> None:
        self._outbox.broadcast(mission_message(record))
        self._records.put(record)
        if record.state == "aborted":  # announced once: an ended mission changes no more
            reason = f": {record.reason}" if record.reason else ""
            text = f"Mission {record.name} of {record.robot} aborted at step {record.current + 1}{reason}"
            self._alert("mission_aborted", text, robot=record.robot, subject=record.id)

    def _release(self, record: MissionRecord) -> None:
        robot, now = record.robot, self._clock()
        if self._control.leases.holder(robot) == holder(record.id):
            self._control.leases.release(robot, holder(record.id))
            self._control.lease_changed(robot, None, holder(record.id), "released", now)


def _saver(record: MissionRecord) -> Callable[[Store], None]:
    return lambda store: store.save_mission(record)
