"""The relay: wires the fleet config, one backend, the hub and the rules together.

``relay.server`` owns sockets and HTTP; this module owns what the relay *does*, independently of aiohttp, by
handing each concern to the module that holds it:

- ``relay.commands``: client frames through the rules to the backend, one ``ack`` or ``error`` each;
- ``relay.control``: leases, the deadman and every path that stops a robot (estop, take-over, disconnect);
- ``relay.streams``: which cameras clients watch, and the binary frames that carry them;
- ``relay.assets``: twins of live maps and robot models built at run time;
- ``relay.supervision``: the ticker (timeouts, aging statuses, backend recovery);
- ``relay.outbox``: what every client is told, and in which lane.

Backend events arrive on the loop thread through :meth:`Relay.on_event` and go out through the hub.
``clock`` (loop time, seconds) is the one source of ``now`` for every rule; tests inject their own.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import sys
import time
from collections.abc import Callable

from . import SERVER_NAME, __version__
from .assets import GeneratedAssets
from .audit import AuditLog, CommandAudit
from .backends import create_backend
from .backends.base import Backend
from .clients import Client, new_client_id
from .commands import CommandHandler
from .config import FleetConfig
from .control import Control
from .description import describe_robot
from .events import (
    CameraError,
    CancelAnswerEvent,
    Event,
    EventSink,
    FrameEvent,
    GateStateEvent,
    Goal,
    MapEvent,
    NavEvent,
    NavFeedbackEvent,
    PathEvent,
    PlaybackEvent,
    PoseEvent,
    RobotModelEvent,
    ScanEvent,
    SensorEvent,
)
from .fleet import FleetState
from .hub import Hub, Transport
from .inspection.service import Inspection
from .loop_lag import LoopLag
from .messages import (
    GoalDescription,
    HelloMessage,
    NavFeedback,
    PlaybackMessage,
    RoomDescription,
    backend_message,
    encode,
    nav_message,
    operators_message,
    path_message,
    playback_message,
    room_descriptions,
    scan_message,
)
from .occupancy import OccupancyGrid, from_map_yaml
from .options import Options
from .outbox import Outbox
from .protocol import PROTOCOL_VERSION, Role, camera_identifier
from .ratelimit import TokenBucket
from .streams import CameraStreams
from .supervision import Supervisor
from .twin.facility import load_facility
from .vantage import vantage

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
    ) -> None:
        options = options or Options()
        self.options = options
        self.config = config
        self.clock = clock
        self.hub = Hub()
        self.fleet = FleetState(config, config.safety.offline_after)
        self.robots = {r.name: r for r in config.robots}
        # Looked up here, not bound as a default: a default would keep the function of import time.
        self.backend: Backend = (backend_factory or create_backend)(config, self.on_event, options)
        self.outbox = Outbox(self.hub, self.fleet)
        self.control = Control(
            config.names,
            self.backend,
            self.fleet,
            self.outbox,
            deadman_timeout=config.safety.deadman_timeout,
            lease_timeout=options.lease_timeout,
            clock=clock,
        )
        self.streams = CameraStreams(self.robots, self.hub, self.backend)
        self.assets = GeneratedAssets(config.scene, self.robots, self.hub)
        self.audit = CommandAudit(AuditLog(options.audit_log) if options.audit_log else None, clock=self.clock)
        self.commands = CommandHandler(
            self.robots,
            self.backend,
            self.fleet,
            self.control,
            self.streams,
            self.outbox,
            self.audit,
            self.map_grid,
        )
        self.inspection = Inspection(
            config, options, backend=self.backend, control=self.control, fleet=self.fleet, hub=self.hub,
            map_grid=self.map_grid, clock=clock,
        )  # fmt: skip
        self.commands.inspection = self.inspection
        self.supervisor = Supervisor(config.names, self.backend, self.control, self.outbox, clock)
        #: The loop's stalls: /healthz's figures, and the dates of client frames read after one (relay.loop_lag).
        self.loop_lag = LoopLag(clock)
        self.started_at = clock()
        self._clients: dict[str, Client] = {}
        self.commands.clients = self._clients
        self._map: OccupancyGrid | None = None  # from robots.yaml's `map`
        self._live_map: OccupancyGrid | None = None  # from the backend's /map
        self._playback: PlaybackMessage | None = None  # the latest `playback` message (bag backend)
        #: The rooms of robots.yaml's scene file (``sim.world``), named in every hello.
        self.rooms: list[RoomDescription] = []

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        # The loop's thread waits up to the interpreter's switch interval each time it wants the GIL back from a
        # worker (planning, rendering, parsing: pure Python that holds it): 5 ms by default, paid at every wake of
        # the loop. Six missions planned at once held an estop's ack 0.4-0.6 s so; 0.5 ms costs the workers a few %.
        sys.setswitchinterval(0.0005)
        if self.config.map is not None:
            # Reading and thresholding a large PGM is milliseconds of numpy work: off the loop.
            self._map = await asyncio.to_thread(from_map_yaml, self.config.map)
        facility = None
        if self.config.sim.world is not None:
            # The scene file names the rooms (shown to operators) and the hazards (inspection targets), whatever
            # the backend; parsing it is ~13 ms for the demo facility: off the loop too.
            facility = await asyncio.to_thread(load_facility, self.config.sim.world)
            self.rooms = room_descriptions(facility.rooms)
        await self.backend.start()
        await self.inspection.start(facility)
        self.audit.started(f"{self.options.host}:{self.options.port}")
        self.supervisor.start()
        self.loop_lag.start()
        logger.info("backend %s started with %d robots", self.backend.name, len(self.robots))

    async def stop(self) -> None:
        """Stop every robot first, then the ticker, the client writers and the backend."""
        await self.control.stop_all("shutdown")
        await self.inspection.stop()
        self.assets.close()
        await self.supervisor.stop()
        self.loop_lag.stop()
        for client in list(self._clients.values()):
            await self._drop_client(client)
        await self.backend.stop()
        self.streams.close()
        self.audit.close()

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
        return self.backend.map_grid() or self._live_map or self._map

    # -- connections ------------------------------------------------------------------------------

    def connect(
        self, transport: Transport, role: Role = "operator", address: str | None = None, *, batch: bool = False
    ) -> Client:
        """``batch``: the client takes state messages in batches (``/ws?batch=1``, relay.hub)."""
        client_id = new_client_id()
        channel = self.hub.add(client_id, transport, batch=batch)
        allowance = TokenBucket.full(self.options.max_message_rate, self.clock())
        client = Client(client_id, role, channel, allowance, address)
        self._clients[client_id] = client
        channel.put_priority(encode(self.hello(client)))
        channel.put_priority(encode(operators_message(self.commands.roster())))
        self.inspection.on_connect(client)
        logger.info("client %s connected as %s", client_id, role)
        return client

    async def disconnect(self, client: Client) -> None:
        if self._clients.get(client.client_id) is not client:
            return
        # Robots this client was driving stop *before* anything else happens.
        await self.control.client_gone(client.client_id, self.clock())
        await self._drop_client(client)
        logger.info("client %s disconnected", client.client_id)

    async def _drop_client(self, client: Client) -> None:
        self._clients.pop(client.client_id, None)
        if client.name is not None:
            self.outbox.operators(self.commands.roster())
        client.cancel_tasks()
        self.commands.snapshots.forget(client.client_id)
        self.audit.forget(client.client_id)
        streams = list(client.channel.streams)
        await self.hub.remove(client.channel)
        self.streams.streams_ended(streams)

    def hello(self, client: Client) -> HelloMessage:
        grid = self.map_grid()
        now = self.clock()
        seen = vantage(grid, self.fleet.positions(now)) if grid is not None else None
        return {
            "identifier": "hello",
            "protocol": PROTOCOL_VERSION,
            "server": {"name": SERVER_NAME, "version": __version__},
            "client_id": client.client_id,
            "role": client.role,
            "scene": {"url": self.assets.scene_url, "map_to_scene": self.assets.map_to_scene()},
            "bounds": list(grid.bounds) if grid is not None else None,
            "vantage": None if seen is None else {"x": seen.x, "y": seen.y, "yaw": seen.yaw},
            "rooms": self.rooms,
            "robots": [describe_robot(r, self.assets.model_urls.get(r.name)) for r in self.config.robots],
            "state": self.fleet.snapshot(now),
            "playback": self._playback,
            "backend": backend_message(self.backend.name, self.backend.failure),
        }

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
        await self.commands.handle_text(client, data, now, now if received is None else received, arrived)

    # -- backend events (always on the loop thread) -----------------------------------------------

    def on_event(self, event: Event) -> None:
        if isinstance(event, PlaybackEvent):
            fields = dataclasses.asdict(event)
            del fields["robot"]  # fleet-wide
            self._playback = playback_message(**fields)
            self.outbox.state(self._playback)
        elif isinstance(event, MapEvent):
            self._live_map = event.grid
            logger.info("map received: %dx%d cells, bounds %s", event.grid.width, event.grid.height, event.grid.bounds)
            self.assets.on_map(event)
        elif event.robot not in self.robots:
            logger.warning("backend reported unknown robot %r; ignored", event.robot)
        elif isinstance(event, RobotModelEvent):
            self.assets.on_model(event)
        else:
            self._on_robot_event(event, self.clock())

    def _on_robot_event(self, event: Event, now: float) -> None:
        if isinstance(event, PoseEvent):
            message = self.fleet.on_pose(event, now)
            self.outbox.state(message)
            if self.outbox.online_changed(event.robot, now):
                self.outbox.status(event.robot, now)
        elif isinstance(event, SensorEvent):
            sensor = self.fleet.on_sensor(event)
            if sensor is not None:
                self.outbox.state(sensor)
        elif isinstance(event, NavEvent):
            self.fleet.on_nav(event)
            self.outbox.status(event.robot, now)
            self.outbox.state(
                nav_message(
                    event.robot, outcome=event.outcome, goal=_goal(event.goal), message=event.message,
                    error_code=event.error_code,
                )
            )  # fmt: skip
            self.inspection.on_nav(event)
        elif isinstance(event, NavFeedbackEvent):
            goal = _goal(event.goal)
            if goal == self.fleet.goal(event.robot):  # the goal it follows now, not one being given up
                feedback = NavFeedback(
                    distance_remaining=event.distance_remaining, eta=event.eta, recoveries=event.recoveries,
                    navigation_time=event.navigation_time,
                )  # fmt: skip
                self.outbox.state(nav_message(event.robot, outcome="started", goal=goal, message="", feedback=feedback))
        elif isinstance(event, CancelAnswerEvent):
            self.outbox.state(
                nav_message(
                    event.robot, outcome="cancelled", goal=_goal(event.goal), message=event.message,
                    confirmed=event.confirmed,
                )
            )  # fmt: skip
        elif isinstance(event, GateStateEvent):
            if event.word == "estop":
                self.control.watchdog_estop(event.robot, now)
        elif isinstance(event, PathEvent):
            self.outbox.state(path_message(event.robot, event.points))
        elif isinstance(event, ScanEvent):
            # Not dataclasses.asdict: it deep-copies the ranges (a third of the relay's time at 1000 scans/s).
            scan = scan_message(
                event.robot,
                stamp=event.stamp,
                frame=event.frame,
                angle_min=event.angle_min,
                angle_increment=event.angle_increment,
                range_max=event.range_max,
                ranges=event.ranges,
            )
            self.outbox.state(scan)
        elif isinstance(event, FrameEvent):
            self.streams.on_frame(event, now)
        elif isinstance(event, CameraError):
            self.streams.camera_failed(camera_identifier(event.robot, event.camera), event.message)


def _goal(goal: Goal | None) -> GoalDescription | None:
    return None if goal is None else GoalDescription(x=goal[0], y=goal[1], yaw=goal[2])
