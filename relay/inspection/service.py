"""Inspection in the relay: targets, missions, captures and findings, wired to the rules every command obeys.

- **Rules**: viewers see targets, missions and findings, and create none (``forbidden``); a mission starts only for
  robots the operator may command (lease, estop latch, recordings), and only once every step was checked
  (relay.inspection.missions); while it runs, the mission holds the robot's lease (relay.inspection.runner).
- **Captures** and what is made of them (findings, regions, targets from a pixel): relay.inspection.captures.
- **Targets**: relay.inspection.target_book (bounded, stored, announced as deltas).
- **Storage** runs on one thread of its own (``WorkPool("store")``); a database that is locked or full pauses the
  mission with the store's message, and the command that needed it gets an ``error`` naming the database.
"""

from __future__ import annotations

import asyncio
import logging
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from ..errors import CommandRejected, ConfigError
from ..events import NavEvent
from ..protocol import ErrorCode, RequestId
from ..work import Busy, WorkPool
from .captures import Captures
from .kml import KmlError, targets_from_kml
from .messages import (
    FINDINGS_ON_CONNECT,
    MISSIONS_ON_CONNECT,
    finding_message,
    mission_message,
)
from .missions import MissionError, MissionPlan, Waypoint, assign, load_mission, resolve, steps_from_wire
from .records import MissionRecord, Step, Target, new_id
from .runner import MissionRunner, holder
from .target_book import TargetBook
from .targets import TARGET_ID, facility_targets, load_targets
from .wire import FindingMark, MissionControl, MissionStart, RegionRequest, TargetAdd, inspection_identifier
from .write_behind import WriteBehind

if TYPE_CHECKING:
    from ..backends.base import Backend
    from ..clients import Client
    from ..config import FleetConfig
    from ..control import Control
    from ..fleet import FleetState
    from ..occupancy import OccupancyGrid
    from ..options import Options
    from ..outbox import Outbox
    from ..stop_notices import StopNotices
    from ..twin.facility import Facility
    from .report import Scope
    from .store import Store

logger = logging.getLogger(__name__)
T = TypeVar("T")


class Inspection:
    def __init__(
        self,
        config: FleetConfig,
        options: Options,
        *,
        backend: Backend,
        control: Control,
        stops: StopNotices,
        fleet: FleetState,
        outbox: Outbox,
        map_grid: Callable[[], OccupancyGrid | None],
        clock: Callable[[], float],
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        self.config, self.options = config, options
        self.robots = {r.name: r for r in config.robots}
        self.backend, self.control, self.fleet, self.outbox = backend, control, fleet, outbox
        self.map_grid, self.clock, self.wall = map_grid, clock, wall_clock
        self.store: Store | None = None
        self.book = TargetBook(config.inspection.max_targets, outbox, self._store_call)
        self.targets = self.book.targets  # read-only here: changed through the book
        self._store_pool = WorkPool("store", workers=1, queue=256)
        #: Reading mission files and planning missions: their own thread, never asyncio's shared pool (six 200-step
        #: missions checked there once held an estop 0.4 s), and a bounded queue (``busy`` beyond it).
        self._planning = WorkPool("planning", workers=1, queue=4)
        self._temporary: tempfile.TemporaryDirectory[str] | None = None
        #: Mission records are stored after their change is announced: a stop never waits for the database.
        self._records = WriteBehind(self._save)
        self.captures = Captures(
            self.robots, backend=backend, fleet=fleet, outbox=outbox, book=self.book, store=self._store,
            map_grid=map_grid, clock=clock, wall_clock=wall_clock,
        )  # fmt: skip
        self.runner = MissionRunner(
            go=self._go, stop=self._stop, capture=self.captures.for_mission, publish=self._publish,
            release=self._release, wall_clock=wall_clock,
        )  # fmt: skip
        stops.follow(self.runner.robot_stopped, self.mission_robots)

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self, facility: Facility | None = None) -> None:
        """``facility``: the scene file (robots.yaml's ``sim.world``), whose hazards become targets."""
        from .store import Store, default_images

        database, images = self.options.database, self.options.images
        if database is None:  # library use and tests: a database of this run only
            self._temporary = tempfile.TemporaryDirectory(prefix="xr-relay-inspection-")
            database = str(Path(self._temporary.name) / "inspection.sqlite")
        if images is None:
            images = str(default_images(database))
        self.store = await self._store_pool.run(lambda: Store.open(database, Path(images)))
        self._records.start()
        store = self.store
        try:
            if facility is not None:
                self.book.load(facility_targets(facility), "the scene's hazards")
            if self.options.targets is not None:
                loaded = await asyncio.to_thread(self._load_targets, Path(self.options.targets))
                self.book.load(loaded, f"--targets {self.options.targets}")
            # What operators and mission files added, as they left it (a stored one replaces the scene's).
            self.book.load(await self._store_pool.run(store.targets), f"the database {store.name}")
        except ValueError as exc:
            raise ConfigError(self.config.source, None, "inspection.max_targets", str(exc)) from None
        await self._load_history(store)
        # The store's name: a path, or the URL without its password.
        logger.info("inspection: %d targets, database %s", len(self.targets), store.name)

    async def _load_history(self, store: Store) -> None:
        """What clients saw before the restart: the newest findings and missions. A mission that was running or
        pending is paused ("the relay restarted"): an operator resumes it from its step, or aborts it."""
        found = await self._store_pool.run(lambda: store.recent_findings(FINDINGS_ON_CONNECT))
        self.captures.recent = [finding_message(f, c.image, c.readings) for f, c in reversed(found)]
        for record in reversed(await self._store_pool.run(lambda: store.missions(MISSIONS_ON_CONNECT))):
            if record.state in ("running", "pending"):
                record = replace(record, state="paused", reason="the relay restarted", updated=self.wall())
                self._records.put(record)
            self.runner.restore(record)

    def _load_targets(self, path: Path) -> list[Target]:
        """A targets file: YAML, or KML/KMZ placemarks placed by robots.yaml's georeference."""
        if path.suffix.lower() in (".kml", ".kmz"):
            try:
                return targets_from_kml(path.read_bytes(), str(path), self.config.georeference)
            except OSError as exc:
                raise KmlError(f"{path}: cannot read it: {exc.strerror or exc}") from None
        return load_targets(path)

    async def stop(self) -> None:
        await self.runner.stop()
        for run in self.runner.runs.values():
            self._records.put(run.record)
        await self._records.close()
        if self.store is not None:
            store = self.store
            await self._store_pool.run(store.close)
        self._store_pool.shutdown()
        self.captures.close()
        self._planning.shutdown()
        if self._temporary is not None:
            self._temporary.cleanup()

    def mission_robots(self) -> set[str]:
        return {run.record.robot for run in self.runner.runs.values() if run.record.state in ("running", "paused")}

    def on_connect(self, client: Client) -> None:
        """A new client learns the targets, the missions and the newest findings after its ``hello``."""
        self.outbox.to(client, self.book.message())
        for record in self.runner.records():
            self.outbox.to(client, mission_message(record))
        for message in self.captures.recent[-FINDINGS_ON_CONNECT:]:
            self.outbox.to(client, message)

    def on_nav(self, event: NavEvent) -> None:
        self.runner.on_nav(event)

    # -- commands ---------------------------------------------------------------------------------

    async def handle(self, client: Client, command: Any, now: float) -> None:
        """Carry out one inspection command; raises CommandRejected (or ProtocolError) when refused."""
        self.control.gate.require_operator(client, inspection_identifier(command), command.id)
        if isinstance(command, MissionStart):
            await self._start(client, command, now)
        elif isinstance(command, MissionControl):
            await self._control(client, command, now)
        elif isinstance(command, FindingMark):
            await self.captures.finding(client, command)
        elif isinstance(command, RegionRequest):
            await self.captures.region(client, command)
        elif isinstance(command, TargetAdd):
            await self.captures.add_target(client, command)

    async def _store(self, work: Callable[[Store], T], request_id: RequestId | None = None) -> T:
        from .store import StoreError, UnknownRecord

        store = self.store
        if store is None:
            raise CommandRejected(ErrorCode.INTERNAL, "the inspection database is not open", request_id)
        try:
            return await self._store_pool.run(lambda: work(store))
        except UnknownRecord as exc:  # the client named something that is not there: its mistake, not the relay's
            raise CommandRejected(ErrorCode.BAD_REQUEST, str(exc), request_id) from None
        except Busy as exc:  # a bounded queue that is full: nothing was done, the client may send it again
            raise CommandRejected(ErrorCode.BUSY, f"inspection database: {exc}", request_id) from None
        except StoreError as exc:
            raise CommandRejected(ErrorCode.INTERNAL, f"inspection database: {exc}", request_id) from None

    async def _store_call(self, work: Callable[[Store], None], request_id: RequestId | None) -> None:
        await self._store(work, request_id)

    async def _start(self, client: Client, command: MissionStart, now: float) -> None:
        plan, placemarks = await self._plan(command)
        if placemarks:
            await self.book.add(placemarks, f"mission/start: {command.file}", command.id)
        robots: dict[str, tuple[Step, ...]]
        if plan.targets:
            unknown = [t for t in plan.targets if t not in self.targets]
            if unknown:
                # Named, a few of them: the site's targets are in the `targets` list every client holds.
                more = f" and {len(unknown) - 5} more" if len(unknown) > 5 else ""
                raise CommandRejected(
                    ErrorCode.BAD_REQUEST,
                    f"mission/start: unknown target(s) {', '.join(t[:64] for t in unknown[:5])}{more}; "
                    f"the site has {len(self.targets)} targets (the `targets` list)",
                    command.id,
                )
            free = {r: self._position(r) for r in self.robots if self._free(client, r, now)}
            where = dict(self.targets)
            positions = {r: p for r, p in free.items() if p is not None}
            try:
                assigned = await self._planning.run(lambda: assign(plan.targets, positions, where))
            except MissionError as exc:
                raise CommandRejected(ErrorCode.BAD_REQUEST, f"mission/start: {exc}", command.id) from None
            except Busy as exc:
                raise CommandRejected(ErrorCode.BUSY, f"mission/start: {exc}; try again shortly", command.id) from None
            robots = {r: tuple(Step("inspect", target=t) for t in ts) for r, ts in assigned.items()}
        else:
            robots = dict(plan.robots)
        for robot in robots:
            if robot not in self.robots:
                raise CommandRejected(ErrorCode.UNKNOWN_ROBOT, f"mission/start: unknown robot {robot!r}", command.id)
            self.control.gate.require_commandable(client, robot, f"mission/start {robot}", command.id, now, moves=True)
            if self.runner.active(robot) is not None:
                raise CommandRejected(
                    ErrorCode.BAD_REQUEST, f"mission/start: {robot} is on a mission already", command.id
                )
        # Every step of every robot is checked before any robot moves.
        waypoints = await self._plan_all(robots, "mission/start", command.id)
        group = new_id("m")
        wall = self.wall()
        records = [
            MissionRecord(f"{group}.{robot}", plan.name, robot, steps, "pending", 0, "", wall, wall, client.client_id)
            for robot, steps in robots.items()
        ]
        for record in records:  # all stored before any robot moves: a full or locked database starts none
            await self._store(_saver(record), command.id)
        for record in records:
            robot = record.robot
            previous = self.control.leases.holder(robot)
            self.control.leases.take(robot, holder(record.id), now)
            self.control.lease_changed(robot, holder(record.id), previous, "acquired", now)
            self.runner.start(record, waypoints[robot])
            logger.info("mission %s started by %s: %s, %d steps", record.id, client.client_id, robot, len(record.steps))

    async def _plan_all(
        self, robots: dict[str, tuple[Step, ...]], identifier: str, request_id: RequestId
    ) -> dict[str, list[Waypoint | None]]:
        """Every step of every robot checked, from where each stands, on the planning pool."""
        grid = self.map_grid()
        where = dict(self.targets)
        starts = {
            r: self._position(r) or (self.robots[r].initial_pose.x, self.robots[r].initial_pose.y) for r in robots
        }

        def check() -> dict[str, list[Waypoint | None]]:
            planner = _planner(grid)
            return {r: resolve(r, steps, where, starts[r], grid, planner) for r, steps in robots.items()}

        try:
            return await self._planning.run(check)
        except MissionError as exc:
            raise CommandRejected(ErrorCode.NO_PATH, f"{identifier}: {exc}", request_id) from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"{identifier}: {exc}; try again shortly", request_id) from None

    async def _plan_steps(self, robot: str, steps: tuple[Step, ...], request_id: RequestId) -> list[Waypoint | None]:
        return (await self._plan_all({robot: steps}, "mission/resume", request_id))[robot]

    async def _plan(self, command: MissionStart) -> tuple[MissionPlan, list[Target]]:
        """The mission asked for, and the targets its file brings (KML/KMZ placemarks): a file is read and parsed
        on the planning pool (a 6000-placemark KMZ once held the loop, and an estop, for 9.8 s)."""
        try:
            if command.file is not None:
                file = command.file
                return await self._planning.run(lambda: self._mission_file(file))
            name = command.name or "mission"
            if command.targets is not None:
                return MissionPlan(name, targets=command.targets), []
            assert command.robot is not None
            return MissionPlan(name, robots=((command.robot, steps_from_wire(command.steps, "mission/start")),)), []
        except (MissionError, KmlError) as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, str(exc), command.id) from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"mission/start: {exc}; try again shortly", command.id) from None

    def _mission_file(self, name: str) -> tuple[MissionPlan, list[Target]]:
        """``missions/<name>.yaml``, or ``<name>.kmz``/``.kml``: its placemarks are targets, visited by the fleet.
        Runs on the planning pool: reads files and the config only."""
        if not TARGET_ID.match(name):
            raise MissionError(f"mission/start: no mission file named {name[:64]!r}")
        folder = self.options.missions_dir
        for suffix in (".yaml", ".kmz", ".kml"):
            path = folder / f"{name}{suffix}"
            if not path.is_file():
                continue
            if suffix == ".yaml":
                return load_mission(path), []
            targets = targets_from_kml(path.read_bytes(), path.name, self.config.georeference)
            if not targets:
                raise MissionError(f"{path.name}: no placemark with a point: nothing to inspect")
            return MissionPlan(name, targets=tuple(t.id for t in targets)), targets
        available = sorted({p.stem for p in folder.glob("*") if p.suffix in (".yaml", ".kmz", ".kml")})
        raise MissionError(f"mission/start: no mission file {name!r}; there are {', '.join(available) or 'none'}")

    def _free(self, client: Client, robot: str, now: float) -> bool:
        holder_now = self.control.leases.holder(robot)
        return (
            self.fleet.online(robot, now)
            and robot not in self.control.latched
            and self.runner.active(robot) is None
            and holder_now in (None, client.client_id)
            and self.backend.command_refusal(robot) is None
        )

    def _position(self, robot: str) -> tuple[float, float] | None:
        pose = self.fleet.snapshot(self.clock())[robot]["pose"]
        return None if pose is None else (pose["x"], pose["y"])

    async def _control(self, client: Client, command: MissionControl, now: float) -> None:
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
        lease = self.control.leases.holder(robot)
        # A mission restored after a restart holds no lease (leases live in memory): free is as good as its own.
        if lease not in (None, holder(run.record.id), client.client_id):
            raise CommandRejected(
                ErrorCode.LEASED, f"mission/{command.action}: {robot} is controlled by {lease}", command.id
            )
        revive = None
        if command.action == "resume":
            if lease == holder(run.record.id):  # held by the mission itself (an estop held it): the other rules
                self.control.gate.require_movable(client, robot, "mission/resume", command.id)
            else:
                self.control.gate.require_commandable(client, robot, "mission/resume", command.id, now, moves=True)
            if self.runner.needs_task(run):  # restored: the rest is planned again from where the robot stands
                revive = await self._plan_steps(run.record.robot, run.record.steps, command.id)
            if lease != holder(run.record.id):  # an operator who took over hands the robot back to the mission
                self.control.leases.take(robot, holder(run.record.id), now)
                self.control.lease_changed(robot, holder(run.record.id), lease, "acquired", now)
        if revive is not None:
            self.runner.revive(run, revive)
            return
        try:
            await self.runner.act(run, command.action, client.client_id)
        except ValueError as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"mission/{command.action}: {exc}", command.id) from None

    # -- what the runner asks of the relay --------------------------------------------------------

    async def _go(self, robot: str, x: float, y: float, yaw: float | None) -> None:
        generation = self.control.supersede(robot)
        self.fleet.set_teleop(robot, False)
        await self.backend.send_goal(robot, x, y, yaw, current=lambda: self.control.generation(robot) == generation)

    async def _stop(self, robot: str) -> None:
        self.control.supersede(robot)
        await self.backend.stop_robot(robot)

    def _publish(self, record: MissionRecord) -> None:
        self.outbox.broadcast(mission_message(record))
        self._records.put(record)

    @property
    def store_failure(self) -> str | None:
        """Why mission records wait to be stored (``/healthz``), or None."""
        return self._records.failure

    async def _save(self, record: MissionRecord) -> None:
        store = self.store
        if store is not None:
            await self._store_pool.run(lambda: store.save_mission(record))

    def _release(self, record: MissionRecord) -> None:
        robot, now = record.robot, self.clock()
        if self.control.leases.holder(robot) == holder(record.id):
            self.control.leases.release(robot, holder(record.id))
            self.control.lease_changed(robot, None, holder(record.id), "released", now)

    # -- reading ----------------------------------------------------------------------------------

    async def image(self, sha: str) -> bytes | None:
        store = self.store
        return None if store is None else await self._store_pool.run(lambda: store.image(sha))

    async def report(self, scope: Scope, kind: str, origin: str) -> str:
        """The report of a mission, a fleet mission's group or a time range as ``kind`` (``report.KINDS``), image
        links under ``origin``. ReportError (a ValueError) for an unknown mission or no database; ReportRefused for
        a range holding too many findings."""
        from . import report

        store = self.store
        if store is None:
            raise report.ReportError("the inspection database is not open")
        grid, config, now = self.map_grid(), self.config, self.wall()

        def build() -> str:
            found = report.collect(store, scope, report.site_of(config, store), now=now)
            return report.render(found, kind, store, grid, report.relay_images(origin))

        return await self._store_pool.run(build)


def _planner(grid: OccupancyGrid | None) -> Any:
    if grid is None:
        return None
    from ..sim.planner import Planner

    return Planner(grid, 0.25)


def _saver(record: MissionRecord) -> Callable[[Store], None]:
    return lambda store: store.save_mission(record)
