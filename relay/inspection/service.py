"""Inspection in the relay: targets, missions, captures and findings, wired to the rules every command obeys.

- **Rules**: viewers see targets, missions and findings, and create none (``forbidden``); a mission starts only for
  robots the operator may command (lease, estop latch, recordings), and only once every step was checked
  (relay.inspection.missions); while it runs, the mission holds the robot's lease (relay.inspection.runner).
- **Captures** and what is made of them (findings, regions, targets from a pixel): relay.inspection.captures.
- **Targets**: relay.inspection.target_book (bounded, stored, announced as deltas).
- **Missions**: relay.inspection.mission_commands (the commands and their rules), relay.inspection.planning (files
  read and steps checked on the planning pool).
- **Alerts** (relay.inspection.alerts): raised through :meth:`Inspection.raise_alert` by findings, readings and
  missions, acknowledged with ``alert/ack``; stored after they are announced, like mission records.
- **Schedules** (relay.inspection.scheduler, schedule_commands): missions started at their times as ``schedule
  <name>``, through the same path as ``mission/start``.
- **Webhooks** (relay.inspection.webhooks): every alert raised or acknowledged, POSTed and signed in the background.
- **Storage** runs on one thread of its own (relay.inspection.storage); a database that is locked or full pauses the
  mission with the store's message, and the command that needed it gets an ``error`` naming the database.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError
from ..fleet.events import NavEvent
from ..station.work import WorkPool
from .alerts import Alerts
from .captures import Captures
from .kml import KmlError, targets_from_kml
from .messages import (
    FINDINGS_ON_CONNECT,
    FINDINGS_PAGE,
    MISSIONS_ON_CONNECT,
    finding_message,
    findings_message,
    mission_message,
    schedules_message,
)
from .mission_commands import MissionCommands
from .planning import MissionPlanning
from .records import AlertRecord, AlertSeverity, DeliveryRecord, MissionRecord, Target
from .schedule_commands import ScheduleCommands
from .scheduler import Scheduler
from .storage import Storage
from .target_book import TargetBook
from .targets import facility_targets, load_targets
from .webhooks import Webhooks
from .wire import (
    AlertAck,
    FindingMark,
    FindingsPage,
    MissionControl,
    MissionStart,
    RegionRequest,
    ScheduleChange,
    ScheduleRemove,
    TargetAdd,
    inspection_identifier,
)
from .write_behind import WriteBehind

if TYPE_CHECKING:
    from ..backends.base import Backend
    from ..cli.options import Options
    from ..config import FleetConfig
    from ..control.control import Control
    from ..control.stop_notices import StopNotices
    from ..fleet.occupancy import OccupancyGrid
    from ..fleet.state import FleetState
    from ..session.clients import Client
    from ..station.outbox import Outbox
    from ..twin.facility import Facility
    from .report import Scope
    from .store import Store

logger = logging.getLogger(__name__)


class Inspection:
    """The inspection commands and what clients learn of targets, missions and findings, over one database."""

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
        marked: Callable[[str | None], None] = lambda target: None,
    ) -> None:
        """``marked``: told the target of every finding an operator marks (a study's task, relay.study.service)."""
        self.config, self.options = config, options
        self.robots = {r.name: r for r in config.robots}
        self.control, self.outbox = control, outbox
        self.map_grid, self.wall = map_grid, wall_clock
        self._storage = Storage(options)
        self.book = TargetBook(config.inspection.max_targets, outbox, self._storage.call)
        self.targets = self.book.targets  # read-only here: changed through the book
        #: Reading mission files and planning missions: their own thread, never asyncio's shared pool (six 200-step
        #: missions checked there once held an estop 0.4 s), and a bounded queue (``busy`` beyond it).
        self._planning = WorkPool("planning", workers=1, queue=4)
        planning = MissionPlanning(
            config, options.missions_dir, self._planning, targets=self.targets, map_grid=map_grid
        )
        #: Mission records are stored after their change is announced: a stop never waits for the database.
        self._records: WriteBehind[MissionRecord] = WriteBehind(self._save)
        self.webhooks = Webhooks(config.inspection.webhooks, self._save_delivery)
        self.alerts = Alerts(outbox, self._storage, self.webhooks.notify, wall_clock=wall_clock)
        self.captures = Captures(
            self.robots, backend=backend, fleet=fleet, outbox=outbox, book=self.book, store=self._storage.call,
            alert=self.raise_alert, map_grid=map_grid, clock=clock, wall_clock=wall_clock, marked=marked,
        )  # fmt: skip
        self.missions = MissionCommands(
            self.robots, backend=backend, control=control, fleet=fleet, outbox=outbox, book=self.book,
            planning=planning, storage=self._storage, records=self._records, capture=self.captures.for_mission,
            alert=self.raise_alert, clock=clock, wall_clock=wall_clock,
        )  # fmt: skip
        self.runner = self.missions.runner
        self.scheduler = Scheduler(
            start=self.missions.start, busy=lambda record, now: self.missions.busy(record.mission.get("robot"), now),
            mission=self._mission_record, storage=self._storage, outbox=outbox, alert=self.raise_alert, clock=clock,
            wall_clock=wall_clock,
        )  # fmt: skip
        self.schedules = ScheduleCommands(
            self.robots, targets=self.targets, planning=planning, storage=self._storage, scheduler=self.scheduler,
            wall_clock=wall_clock,
        )  # fmt: skip
        stops.follow(self.runner.robot_stopped, self.mission_robots)

    @property
    def store(self) -> Store | None:
        """The database, once :meth:`start` opened it."""
        return self._storage.store

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self, facility: Facility | None = None) -> None:
        """``facility``: the scene file (robots.yaml's ``sim.world``), whose hazards become targets."""
        store = await self._storage.open()
        self._records.start()
        try:
            if facility is not None:
                self.book.load(facility_targets(facility), "the scene's hazards")
            if self.options.targets is not None:
                loaded = await asyncio.to_thread(self._load_targets, Path(self.options.targets))
                self.book.load(loaded, f"--targets {self.options.targets}")
            # What operators and mission files added, as they left it (a stored one replaces the scene's).
            self.book.load(await self._storage.run(store.targets), f"the database {store.name}")
        except ValueError as exc:
            raise ConfigError(self.config.source, None, "inspection.max_targets", str(exc)) from None
        await self._load_history(store)
        await self.alerts.start(store)
        self.webhooks.start()
        await self.scheduler.start(store)  # after the alerts: runs missed while the relay was down raise some
        # The store's name: a path, or the URL without its password.
        logger.info("inspection: %d targets, database %s", len(self.targets), store.name)

    async def _load_history(self, store: Store) -> None:
        """What clients saw before the restart: the newest findings and missions. A mission that was running or
        pending is paused ("the relay restarted"): an operator resumes it from its step, or aborts it."""
        found = await self._storage.run(lambda: store.recent_findings(FINDINGS_ON_CONNECT))
        self.captures.recent = [finding_message(f, c.image, c.readings, b) for f, c, b in reversed(found)]
        for record in reversed(await self._storage.run(lambda: store.missions(MISSIONS_ON_CONNECT))):
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
        await self.scheduler.stop()  # first: no run starts while the rest stops
        await self.runner.stop()
        for run in self.runner.runs.values():
            self._records.put(run.record)
        await self._records.close()
        await self.alerts.close()
        await self.webhooks.stop()
        await self._storage.close()
        self.captures.close()
        self._planning.shutdown()

    def mission_robots(self) -> set[str]:
        return {run.record.robot for run in self.runner.runs.values() if run.record.state in ("running", "paused")}

    def on_connect(self, client: Client) -> None:
        """A new client learns the targets, the missions and the newest findings after its ``hello``."""
        self.outbox.to(client, self.book.message())
        for record in self.runner.records():
            self.outbox.to(client, mission_message(record))
        for message in self.captures.recent[-FINDINGS_ON_CONNECT:]:
            self.outbox.to(client, message)
        self.alerts.on_connect(client)
        self.outbox.to(client, schedules_message(self.scheduler.states()))

    def _mission_record(self, mission_id: str) -> MissionRecord | None:
        run = self.runner.runs.get(mission_id)
        return None if run is None else run.record

    def raise_alert(
        self,
        kind: str,
        text: str,
        *,
        robot: str | None = None,
        subject: str | None = None,
        severity: AlertSeverity = "warning",
    ) -> AlertRecord:
        """Raise an alert (relay.inspection.alerts): every client gets it now, the database and the webhooks after.
        ``kind`` says what raised it (``anomaly``, ``threshold``, ``mission_aborted``, ...); ``subject`` the finding,
        capture, mission or target it is about. Awaits nothing."""
        return self.alerts.raise_alert(kind, text, robot=robot, subject=subject, severity=severity)

    def on_nav(self, event: NavEvent) -> None:
        self.runner.on_nav(event)

    # -- commands ---------------------------------------------------------------------------------

    async def handle(self, client: Client, command: Any, now: float) -> None:
        """Carry out one inspection command; raises CommandRejected (or ProtocolError) when refused."""
        if isinstance(command, FindingsPage):
            await self._page(client, command)  # what a viewer sees already, further back
            return
        self.control.gate.require(client, "inspect", inspection_identifier(command), command.id)
        if isinstance(command, MissionStart):
            await self.missions.start(client, command, now)
        elif isinstance(command, MissionControl):
            await self.missions.control(client, command, now)
        elif isinstance(command, FindingMark):
            await self.captures.finding(client, command)
        elif isinstance(command, RegionRequest):
            await self.captures.region(client, command)
        elif isinstance(command, TargetAdd):
            await self.captures.add_target(client, command)
        elif isinstance(command, AlertAck):
            await self.alerts.acknowledge(client, command)
        elif isinstance(command, ScheduleChange):
            await self.schedules.change(client, command)
        elif isinstance(command, ScheduleRemove):
            await self.schedules.remove(command)

    async def _page(self, client: Client, command: FindingsPage) -> None:
        """A page of the findings history from the database (off the loop), newest first."""
        store, limit = self.store, command.limit or FINDINGS_PAGE
        rows = []
        if store is not None:
            rows = await self._storage.run(lambda: store.recent_findings(limit + 1, command.before))
        page = [finding_message(f, c.image, c.readings, b) for f, c, b in rows[:limit]]
        self.outbox.to(client, findings_message(command.id, page, more=len(rows) > limit))

    # -- mission records --------------------------------------------------------------------------

    @property
    def store_failure(self) -> str | None:
        """Why mission records or alerts wait to be stored (``/healthz``), or None."""
        return self._records.failure or self.alerts.failure or self.scheduler.failure

    async def _save(self, record: MissionRecord) -> None:
        store = self.store
        if store is not None:
            await self._storage.run(lambda: store.save_mission(record))

    async def _save_delivery(self, delivery: DeliveryRecord) -> None:
        store = self.store
        if store is not None:
            await self._storage.run(lambda: store.add_delivery(delivery))

    # -- reading ----------------------------------------------------------------------------------

    async def deliveries(self, limit: int) -> list[DeliveryRecord]:
        """The newest webhook delivery attempts, newest first (``/webhooks/deliveries``)."""
        store = self.store
        return [] if store is None else await self._storage.run(lambda: store.deliveries(limit))

    async def image(self, sha: str) -> bytes | None:
        store = self.store
        return None if store is None else await self._storage.run(lambda: store.image(sha))

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

        return await self._storage.run(build)
