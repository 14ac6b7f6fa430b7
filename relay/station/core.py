"""The relay: wires the fleet config, one backend, the hub and the rules together.

``relay.net.server`` owns sockets and HTTP; this module owns what the relay *does*, independently of aiohttp, by
handing each concern to the module that holds it:

- ``relay.session.commands``: client frames through the rules to the backend, one ``ack`` or ``error`` each;
- ``relay.control.control``: leases, the deadman and every path that stops a robot (estop, take-over, disconnect);
- ``relay.media.streams``: which cameras clients watch, and the binary frames that carry them;
- ``relay.station.assets``: twins of live maps and robot models built at run time;
- ``relay.station.supervision``: the ticker (timeouts, aging statuses, backend recovery);
- ``relay.station.outbox``: what every client is told, and in which lane.

Backend events arrive on the loop thread through :meth:`Relay.on_event` and go out through the hub.
``clock`` (loop time, seconds) is the one source of ``now`` for every rule; tests inject their own.
"""

from __future__ import annotations

import asyncio
import logging
import sys
import time
from collections.abc import Callable
from pathlib import Path

import orjson

from ..backends import create_backend
from ..backends.base import Backend
from ..cli.options import Options
from ..config import FleetConfig
from ..control.arm_control import ArmControl
from ..control.control import Control
from ..control.stop_notices import StopNotices
from ..fleet.events import (
    Event,
    EventSink,
)
from ..fleet.latency import StageLatency
from ..fleet.occupancy import OccupancyGrid, from_map_yaml
from ..fleet.state import FleetState
from ..fleet.vantage import vantage
from ..inspection.service import Inspection
from ..mapping.fusion import MapFusion, map_path
from ..mapping.stream import MapStream
from ..media.streams import CameraStreams
from ..net.loop_lag import LoopLag
from ..replay.recorder import SessionRecorder
from ..session.clients import Client, new_client_id, roster
from ..session.commands import CommandHandler
from ..session.protocol import Role
from ..session.ratelimit import TokenBucket
from ..session.snapshots import Snapshots
from ..study.observer import StudyEvents
from ..study.service import StudyService
from ..twin.facility import load_facility
from .assets import GeneratedAssets
from .audit import AuditLog, CommandAudit
from .event_routing import EventRouter
from .hello import hello_message
from .hub import Hub, Transport
from .messages import (
    HelloMessage,
    RoomDescription,
    operators_message,
    room_descriptions,
)
from .outbox import Outbox
from .supervision import Supervisor

logger = logging.getLogger(__name__)

BackendFactory = Callable[[FleetConfig, EventSink, Options], Backend]


class Relay:
    """One relay process's state and the wiring of its parts."""

    def __init__(
        self,
        config: FleetConfig,
        options: Options | None = None,
        *,
        backend_factory: BackendFactory | None = None,
        clock: Callable[[], float] = time.monotonic,
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        """``clock``: the relay's monotonic time (leases, deadman); ``wall_clock``: the time of day (records,
        schedules). Tests pass clocks they move by hand."""
        options = options or Options()
        self.options = options
        self.config = config
        self.clock = clock
        self.hub = Hub()
        self.fleet = FleetState(config, config.safety.offline_after)
        self.robots = {r.name: r for r in config.robots}
        # Looked up here, not bound as a default: a default would keep the function of import time.
        self.backend: Backend = (backend_factory or create_backend)(config, self.on_event, options)
        #: The session's recording, when asked for (--record-session): what goes out and what comes in.
        self.recorder = SessionRecorder(Path(options.record_session)) if options.record_session else None
        self.outbox = Outbox(self.hub, self.fleet, self.recorder.record if self.recorder else None)
        study_events = StudyEvents()  # what a study's task running counts (the study service sets its active run)
        audit_log = AuditLog(options.audit_log) if options.audit_log else None
        self.audit = CommandAudit(audit_log, clock=self.clock, outcomes=study_events.observe)
        stops = StopNotices()
        self.control = Control(
            config.names,
            self.backend,
            self.fleet,
            self.outbox,
            self.audit,
            stops,
            deadman_timeout=config.safety.deadman_timeout,
            lease_timeout=options.lease_timeout,
            clock=clock,
            estop_reset=config.safety.estop_reset,
        )
        #: The study the relay runs (--study), fed by the commands, findings and goals below.
        self.study = StudyService(
            options.study, Path(options.study_runs), config.names, backend=self.backend, control=self.control,
            fleet=self.fleet, outbox=self.outbox, map_grid=self.map_grid, rooms=lambda: self.rooms, clock=clock,
            events=study_events,
        )  # fmt: skip
        self.streams = CameraStreams(self.robots, self.hub, self.outbox, self.backend)
        self.assets = GeneratedAssets(config.scene, self.robots, self.outbox)
        self.inspection = Inspection(
            config, options, backend=self.backend, control=self.control, stops=stops, fleet=self.fleet,
            outbox=self.outbox, map_grid=self.map_grid, clock=clock, wall_clock=wall_clock,
            marked=self.study.events.finding,
        )  # fmt: skip
        self._clients: dict[str, Client] = {}
        #: The arms: their chains, latest joints, commands and deadman (relay.control.arm_control).
        self.arms = ArmControl(
            self.robots, self.backend, self.control.gate, self.outbox, self.control.generation,
            deadman_timeout=config.safety.deadman_timeout,
        )  # fmt: skip
        #: How late each robot's poses, pictures and commands are where the relay sees them (/metrics).
        self.latency = StageLatency(wall_clock)
        self.commands = CommandHandler(
            self.robots,
            self.backend,
            self.fleet,
            self.control,
            self.streams,
            self.outbox,
            self.audit,
            self.map_grid,
            self.inspection,
            self._clients,
            Snapshots(self.robots, self.backend, self.streams, self.outbox),
            self.latency,
            self.arms,
            self.study,
            wall_clock,
        )
        self.supervisor = Supervisor(config.names, self.backend, self.control, self.arms, self.outbox, clock)
        #: The loop's stalls: /healthz's figures, and the dates of client frames read after one (relay.net.loop_lag).
        self.loop_lag = LoopLag(clock)
        self.started_at = clock()
        self._map: OccupancyGrid | None = None  # from robots.yaml's `map`
        #: The live 3D map (issue #33), with robots.yaml's `cloud`.
        self.fusion = MapFusion(config.cloud, map_path(options.database)) if config.cloud is not None else None
        self.map_stream = MapStream(self.hub, self.fusion) if self.fusion is not None else None
        self.router = EventRouter(
            self.robots, self.fleet, self.outbox, self.assets, self.streams, self.control, self.inspection,
            self.latency, clock, self.arms, self.fusion.submit if self.fusion is not None else None,
            reached=self.study.events.goal_reached,
        )  # fmt: skip
        #: The rooms of robots.yaml's scene file (``sim.world``), named in every hello.
        self.rooms: list[RoomDescription] = []

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        # The loop's thread waits up to the interpreter's switch interval each time it wants the GIL back from a
        # worker (planning, rendering, parsing: pure Python that holds it): 5 ms by default, paid at every wake of
        # the loop. Six missions planned at once held an estop's ack 0.4-0.6 s so; 0.5 ms costs the workers a few %.
        sys.setswitchinterval(0.0005)
        if self.recorder is not None:
            await asyncio.to_thread(self.recorder.open)  # creates the file: a place it cannot write stops the start
        if self.config.map is not None:
            # Reading and thresholding a large PGM is milliseconds of numpy work: off the loop.
            self._map = await asyncio.to_thread(from_map_yaml, self.config.map)
        facility = None
        if self.config.sim.world is not None:
            # The scene file names the rooms (shown to operators) and the hazards (inspection targets), whatever
            # the backend; parsing it is ~13 ms for the demo facility: off the loop too.
            facility = await asyncio.to_thread(load_facility, self.config.sim.world)
            self.rooms = room_descriptions(facility.rooms)
        await self.study.start()  # a bad study file stops the start here, naming its line and field
        await self.arms.start()
        if self.fusion is not None and self.map_stream is not None:
            await self.fusion.start()
            self.map_stream.start()
        await self.backend.start()
        await self.inspection.start(facility)
        self.audit.started(f"{self.options.host}:{self.options.port}")
        self.supervisor.start()
        self.loop_lag.start()
        logger.info("backend %s started with %d robots", self.backend.name, len(self.robots))

    async def stop(self) -> None:
        """Stop every robot first, then the ticker, the client writers and the backend."""
        await self.control.stop_all("shutdown")
        await self.study.stop()  # its last changes written
        await self.inspection.stop()
        self.assets.close()
        await self.supervisor.stop()
        self.loop_lag.stop()
        for client in list(self._clients.values()):
            await self._drop_client(client)
        await self.backend.stop()
        if self.fusion is not None and self.map_stream is not None:
            await self.map_stream.stop()
            await self.fusion.stop()
        self.streams.close()
        self.arms.close()
        self.audit.close()
        if self.recorder is not None:
            await asyncio.to_thread(self.recorder.close)  # what is queued, then MCAP's summary and footer

    async def stop_all_robots(self, reason: str) -> None:
        await self.control.stop_all(reason)

    @property
    def clients(self) -> int:
        return len(self._clients)

    @property
    def generated(self) -> dict[str, bytes]:
        """GLB files built at run time, by name (served under ``/scenes/generated``)."""
        return self.assets.files

    @property
    def model_urls(self) -> dict[str, str]:
        return self.assets.model_urls

    def uptime(self) -> float:
        return self.clock() - self.started_at

    def map_grid(self) -> OccupancyGrid | None:
        """The map goals are checked against: the backend's own, the live /map, or robots.yaml's."""
        return self.backend.map_grid() or self.router.live_map or self._map

    # -- connections ------------------------------------------------------------------------------

    def connect(
        self,
        transport: Transport,
        role: Role = "operator",
        address: str | None = None,
        *,
        batch: bool = False,
        user: str | None = None,
    ) -> Client:
        """``batch``: the client takes state messages in batches (``/ws?batch=1``, relay.station.hub); ``user``: the
        account it signed in with (relay/net/sign_in.py), its name everywhere."""
        client_id = new_client_id()
        channel = self.hub.add(client_id, transport, batch=batch)
        allowance = TokenBucket.full(self.options.max_message_rate, self.clock())
        client = Client(client_id, role, channel, allowance, address, name=user, user=user)
        self._clients[client_id] = client
        self.outbox.to(client, self.hello(client))
        self.outbox.to(client, operators_message(roster(self._clients)))
        if self.router.valve is not None:  # the facility's valve, as it stands (it is reported only when it changes)
            self.outbox.to(client, self.router.valve)
        self.inspection.on_connect(client)
        self.study.on_connect(client)
        logger.info("client %s connected as %s%s", client_id, role, f" ({user})" if user else "")
        return client

    async def disconnect(self, client: Client) -> None:
        if self._clients.get(client.client_id) is not client:
            return
        # Robots and arms this client was driving stop *before* anything else happens.
        await self.arms.client_gone(client.client_id)
        await self.control.client_gone(client.client_id, self.clock())
        await self._drop_client(client)
        logger.info("client %s disconnected", client.client_id)

    async def _drop_client(self, client: Client) -> None:
        self._clients.pop(client.client_id, None)
        if client.name is not None:
            self.outbox.operators(roster(self._clients))
        client.cancel_tasks()
        for part in (self.commands.snapshots, self.audit, self.study.events):  # what each kept of the client
            part.forget(client.client_id)
        streams = list(client.channel.streams)
        await self.hub.remove(client.channel)
        self.streams.streams_ended(streams)

    def hello(self, client: Client) -> HelloMessage:
        grid = self.map_grid()
        now = self.clock()
        seen = vantage(grid, self.fleet.positions(now)) if grid is not None else None
        return hello_message(
            client.client_id, client.role, grid=grid, vantage=seen, assets=self.assets, rooms=self.rooms,
            robots=self.config.robots, state=self.fleet.snapshot(now), playback=self.router.playback,
            backend=self.backend,
        )  # fmt: skip

    # -- client frames ----------------------------------------------------------------------------

    def handle_binary(self, client: Client) -> None:
        self.hub.counters.messages_in += 1
        self.commands.handle_binary(client)

    async def handle_text(
        self, client: Client, data: str | bytes, received: float | None = None, arrived: float | None = None
    ) -> None:
        """Handle one text frame read at ``received`` (the relay's clock; default now), its bytes in the relay since
        ``arrived`` at the latest. Only unexpected failures propagate (the server then closes with 1011)."""
        self.hub.counters.messages_in += 1
        now = self.clock()
        if self.recorder is not None:
            # Wrapped, so that the channel holds JSON even for a frame that is not: the relay answers those too.
            text = data if isinstance(data, str) else data.decode("utf-8", "replace")
            self.recorder.record(f"/in/{client.client_id}", orjson.dumps({"frame": text}))
        await self.commands.handle_text(client, data, now, now if received is None else received, arrived)

    # -- backend events (always on the loop thread) -----------------------------------------------

    def on_event(self, event: Event) -> None:
        self.router.on_event(event)
