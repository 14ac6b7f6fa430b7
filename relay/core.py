"""The relay: client commands through the safety rules to the backend, backend events out through the hub.

``relay.server`` owns sockets and HTTP; this module owns what the relay *does*, independently of aiohttp:

- every client frame is parsed by ``relay.protocol``; a bad one gets exactly one ``error`` and changes nothing;
- every command with an ``id`` gets exactly one ``ack`` or ``error`` with that id;
- velocities are clamped, goals checked against the map, and the deadman stops a robot whose operator
  fell silent (``safety.deadman_timeout``) or disconnected;
- ``estop`` stops every (or one) robot at once, cancels goals, and is announced to every client ahead of
  anything else they have queued.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import hashlib
import itertools
import logging
import secrets
import time
from collections.abc import Awaitable
from dataclasses import dataclass, field

from . import SERVER_NAME, __version__
from .audit import AuditLog
from .backends import create_backend
from .backends.base import Backend
from .config import FleetConfig, Robot
from .errors import CommandRejected, ProtocolError
from .events import (
    Event,
    FrameEvent,
    MapEvent,
    NavEvent,
    PlaybackEvent,
    PoseEvent,
    RobotModelEvent,
    ScanEvent,
    SensorEvent,
)
from .fleet import FleetState
from .hub import Channel, Hub, Transport
from .leases import LeaseTable
from .occupancy import OccupancyGrid, from_map_yaml
from .options import Options
from .protocol import (
    PROTOCOL_VERSION,
    Cancel,
    CmdVel,
    Command,
    ErrorCode,
    EStop,
    FrameHeader,
    GoalPose,
    HelloMessage,
    Lease,
    Lens,
    Ping,
    Playback,
    RequestId,
    RobotDescription,
    Role,
    Snapshot,
    Stream,
    Transform2D,
    ack_message,
    backend_message,
    command_identifier,
    encode,
    encode_frame,
    error_message,
    estop_message,
    lease_message,
    model_message,
    parse_command,
    playback_message,
    pong_message,
    scan_message,
    scene_message,
)
from .safety import Deadman, check_goal, clamp_velocity
from .twin.map_twin import grid_to_glb
from .twin.urdf import robot_description_glb

logger = logging.getLogger(__name__)

#: How often the deadman is checked; with a 0.5 s timeout a silent operator's robot stops within 0.55 s.
DEADMAN_PERIOD = 0.05
#: How often every robot's status (its data age) is sent even when nothing else changed.
STATUS_PERIOD = 1.0
#: Where twins built from live maps are served.
GENERATED_SCENES = "/scenes/generated"
#: How often a failed backend is asked to recover.
RECOVERY_PERIOD = 3.0


@dataclass
class Client:
    """One connected client, as the relay sees it."""

    client_id: str
    role: Role
    channel: Channel
    address: str | None = None
    #: Token bucket of the message rate limit: (tokens left, loop time of the last refill).
    allowance: tuple[float, float] = (0.0, 0.0)
    tasks: set[asyncio.Task[None]] = field(default_factory=set)


def lens_description(robot: Robot, camera_name: str) -> Lens:
    camera = robot.camera(camera_name)
    assert camera is not None
    lens: Lens = {"model": camera.lens.model, "fov": camera.lens.fov}
    if camera.lens.k is not None and camera.lens.d is not None:
        lens["K"] = list(camera.lens.k)
        lens["D"] = list(camera.lens.d)
    return lens


def describe_robot(robot: Robot, model_url: str | None = None) -> RobotDescription:
    return {
        "name": robot.name,
        "colour": robot.colour,
        "model": model_url or robot.model or "",
        "cameras": [
            {
                "name": c.name,
                "identifier": f"{robot.name}/camera/{c.name}",
                "lens": lens_description(robot, c.name),
                "width": c.width,
                "height": c.height,
            }
            for c in robot.cameras
        ],
        "sensors": [
            {"name": s.name, "unit": s.unit, "warn_above": s.warn_above, "warn_below": s.warn_below}
            for s in robot.sensors
        ],
        "limits": {"linear": robot.limits.linear, "angular": robot.limits.angular},
    }


class Relay:
    """Ties the fleet config, one backend, the hub and the safety rules together."""

    def __init__(self, config: FleetConfig, options: Options | None = None) -> None:
        options = options or Options()
        self.options = options
        self.config = config
        self.hub = Hub()
        self.fleet = FleetState(config, config.safety.offline_after)
        self.deadman = Deadman(config.safety.deadman_timeout)
        self.leases = LeaseTable(options.lease_timeout)
        self._robots = {r.name: r for r in config.robots}
        self.backend: Backend = create_backend(config, self.on_event, options)
        self.audit = AuditLog(options.audit_log) if options.audit_log else None
        self.started_at = time.monotonic()
        self._clients: dict[str, Client] = {}
        self._ids = itertools.count(1)
        self._frame_seq: dict[str, int] = {}
        self._ticker: asyncio.Task[None] | None = None
        self._map: OccupancyGrid | None = None  # from robots.yaml's `map`
        self._live_map: OccupancyGrid | None = None  # from the backend's /map
        self._playback: dict[str, object] | None = None  # the latest `playback` message (bag backend)
        self._reported_failure: str | None = None
        #: The twin clients load: robots.yaml's, or one built from a live map (served from `generated`).
        self.scene_url: str | None = config.scene.url
        self.generated: dict[str, bytes] = {}
        self.model_urls: dict[str, str] = {}  # robots whose model was built from robot_description
        self._model_tasks: set[asyncio.Task[None]] = set()
        self._pending_map: MapEvent | None = None
        self._twin_task: asyncio.Task[None] | None = None
        self._next_recovery = 0.0
        self._was_online: dict[str, bool] = {name: False for name in self._robots}

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        if self.config.map is not None:
            # Reading and thresholding a large PGM is milliseconds of numpy work: off the loop.
            self._map = await asyncio.to_thread(from_map_yaml, self.config.map)
        await self.backend.start()
        self._ticker = asyncio.get_running_loop().create_task(self._tick(), name="relay-ticker")
        logger.info("backend %s started with %d robots", self.backend.name, len(self._robots))

    async def stop(self) -> None:
        """Stop every robot first, then the ticker, the client writers and the backend."""
        await self.stop_all_robots("shutdown")
        if self._twin_task is not None:
            self._twin_task.cancel()
        for task in list(self._model_tasks):
            task.cancel()
        if self._ticker is not None:
            self._ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._ticker
        for client in list(self._clients.values()):
            await self._drop_client(client)
        await self.backend.stop()
        if self.audit is not None:
            self.audit.close()

    async def stop_all_robots(self, reason: str) -> None:
        robots = list(self._robots)
        for robot in robots:
            self.deadman.release_robot(robot)
            self.fleet.set_teleop(robot, False)
        results = await asyncio.gather(*(self.backend.stop_robot(r) for r in robots), return_exceptions=True)
        for robot, result in zip(robots, results, strict=True):
            if isinstance(result, BaseException):
                logger.error("could not stop %s (%s): %r", robot, reason, result)
        logger.info("all robots stopped (%s)", reason)

    @property
    def clients(self) -> int:
        return len(self._clients)

    def uptime(self) -> float:
        return time.monotonic() - self.started_at

    def map_grid(self) -> OccupancyGrid | None:
        """The map goals are checked against: the backend's own, the live /map, or robots.yaml's."""
        return self.backend.map_grid() or self._live_map or self._map

    # -- connections ------------------------------------------------------------------------------

    def connect(self, transport: Transport, role: Role = "operator", address: str | None = None) -> Client:
        client_id = f"c{next(self._ids)}-{secrets.token_hex(3)}"
        channel = self.hub.add(client_id, transport)
        client = Client(client_id, role, channel, address, (2 * self.options.max_message_rate, time.monotonic()))
        self._clients[client_id] = client
        channel.put_priority(encode(self.hello(client)))
        logger.info("client %s connected as %s", client_id, role)
        return client

    async def disconnect(self, client: Client) -> None:
        if self._clients.get(client.client_id) is not client:
            return
        # Robots this client was driving stop *before* anything else happens.
        for robot in self.deadman.release_client(client.client_id):
            await self._stop_robot(robot, f"operator {client.client_id} disconnected")
        # Its leases end, and a robot it had sent somewhere stops too: nobody is watching it any more.
        for robot in self.leases.release_client(client.client_id):
            await self._halt(robot, f"lease holder {client.client_id} disconnected")
            self._lease_changed(robot, None, client.client_id, "disconnected")
        await self._drop_client(client)
        logger.info("client %s disconnected", client.client_id)

    async def _drop_client(self, client: Client) -> None:
        self._clients.pop(client.client_id, None)
        for task in list(client.tasks):
            task.cancel()
        streams = list(client.channel.streams)
        await self.hub.remove(client.channel)
        for identifier in streams:
            self._update_stream_demand(identifier)

    def hello(self, client: Client) -> HelloMessage:
        grid = self.map_grid()
        now = time.monotonic()
        return {
            "identifier": "hello",
            "protocol": PROTOCOL_VERSION,
            "server": {"name": SERVER_NAME, "version": __version__},
            "client_id": client.client_id,
            "role": client.role,
            "scene": {"url": self.scene_url, "map_to_scene": self._map_to_scene()},
            "bounds": list(grid.bounds) if grid is not None else None,
            "robots": [describe_robot(r, self.model_urls.get(r.name)) for r in self.config.robots],
            "state": self.fleet.snapshot(now),
            "playback": self._playback,
            "backend": backend_message(self.backend.name, self.backend.failure),
        }

    # -- client frames ----------------------------------------------------------------------------

    def handle_binary(self, client: Client) -> None:
        self.hub.counters.messages_in += 1
        self._reply_error(client, None, ErrorCode.UNSUPPORTED, "binary frames from clients are not defined in v1")

    async def handle_text(self, client: Client, data: str | bytes) -> None:
        """Handle one text frame. Only unexpected failures propagate (the server then closes with 1011)."""
        self.hub.counters.messages_in += 1
        try:
            command = parse_command(data, self._robots)
        except ProtocolError as exc:
            self._reply_error(client, exc.request_id, exc.code, exc.message)
            self._audit(client, exc.identifier, exc.request_id, None, exc)
            return
        request_id = getattr(command, "id", None)
        if not isinstance(command, EStop) and not self._within_rate(client):
            # Dropped before it can reach a robot; an estop is never held back.
            error = ProtocolError(
                ErrorCode.RATE_LIMITED,
                f"more than {self.options.max_message_rate:g} messages a second; this one was dropped",
                request_id,
            )
            self._reply_error(client, request_id, error.code, error.message)
            self._audit_command(client, command, error)
            return
        if isinstance(command, Snapshot):
            # Rendering or waiting for the next camera frame takes a while: do not hold up this
            # client's later frames (an estop among them) behind it.
            self._spawn(client, self._run(client, command, self._snapshot(client, command)))
            return
        try:
            await self._dispatch(client, command)
        except ProtocolError as exc:
            exc.request_id = request_id if exc.request_id is None else exc.request_id
            self._reply_error(client, exc.request_id, exc.code, exc.message)
            self._audit_command(client, command, exc)
            return
        self._audit_command(client, command, None)

    def _within_rate(self, client: Client) -> bool:
        rate = self.options.max_message_rate
        tokens, last = client.allowance
        now = time.monotonic()
        tokens = min(2 * rate, tokens + (now - last) * rate)
        if tokens < 1.0:
            client.allowance = (tokens, now)
            return False
        client.allowance = (tokens - 1.0, now)
        return True

    def _audit_command(self, client: Client, command: Command, error: ProtocolError | None) -> None:
        if isinstance(command, Ping):
            return
        values = {k: v for k, v in dataclasses.asdict(command).items() if k not in ("robot", "id")}
        self._audit(client, command_identifier(command), getattr(command, "id", None), values, error)

    def _audit(
        self,
        client: Client,
        identifier: str | None,
        request_id: RequestId | None,
        values: dict[str, object] | None,
        error: ProtocolError | None,
    ) -> None:
        if self.audit is None:
            return
        self.audit.record(
            client=client.client_id,
            role=client.role,
            address=client.address,
            identifier=identifier,
            request_id=request_id,
            values=values,
            outcome="refused" if error else "accepted",
            code=error.code if error else None,
            message=error.message if error else None,
        )

    def _spawn(self, client: Client, coro: Awaitable[None]) -> None:
        task: asyncio.Task[None] = asyncio.ensure_future(coro)
        client.tasks.add(task)
        task.add_done_callback(client.tasks.discard)

    async def _run(self, client: Client, command: Snapshot, coro: Awaitable[None]) -> None:
        try:
            await coro
        except ProtocolError as exc:
            exc.request_id = command.id if exc.request_id is None else exc.request_id
            self._reply_error(client, exc.request_id, exc.code, exc.message)
            self._audit_command(client, command, exc)
        except Exception:
            logger.exception("command %r of client %s failed", command.id, client.client_id)
            self._reply_error(client, command.id, ErrorCode.INTERNAL, "the relay failed on this command; see its log")
        else:
            self._audit_command(client, command, None)

    def _reply(self, client: Client, message: dict[str, object]) -> None:
        client.channel.put_priority(encode(message))

    def _reply_error(self, client: Client, request_id: RequestId | None, code: str, message: str) -> None:
        logger.debug("error to %s: %s %s", client.client_id, code, message)
        self._reply(client, error_message(request_id, code, message))

    def _require_operator(self, client: Client, identifier: str, request_id: RequestId | None) -> None:
        if client.role != "operator":
            raise ProtocolError(ErrorCode.FORBIDDEN, f"{identifier}: viewers cannot command robots", request_id)

    def _require_commandable(self, client: Client, robot: str, identifier: str, request_id: RequestId | None) -> None:
        """Operator role, a robot that is not a recording, and the robot's lease (taken when free)."""
        self._require_operator(client, identifier, request_id)
        refusal = self.backend.command_refusal(robot)
        if refusal is not None:
            raise CommandRejected(ErrorCode.RECORDING, f"{identifier}: {refusal}", request_id)
        allowed, before = self.leases.use(robot, client.client_id, time.monotonic())
        if not allowed:
            raise CommandRejected(
                ErrorCode.LEASED,
                f"{identifier}: {robot} is controlled by {before}; send {robot}/lease with force: true to take over",
                request_id,
            )
        if before is None:
            self._lease_changed(robot, client.client_id, None, "acquired")

    def _lease_changed(self, robot: str, holder: str | None, previous: str | None, reason: str) -> None:
        logger.info("lease of %s: %s -> %s (%s)", robot, previous, holder, reason)
        self.fleet.set_controller(robot, holder)
        # Priority: the operator who lost a robot must learn it before anything else they have queued.
        self.hub.broadcast_priority(encode(lease_message(robot, holder=holder, previous=previous, reason=reason)))
        self._publish_status(robot)

    async def _halt(self, robot: str, reason: str) -> None:
        """Zero velocity and no goal: before a lease changes hands."""
        logger.info("stopping %s: %s", robot, reason)
        self.deadman.release_robot(robot)
        self.fleet.set_teleop(robot, False)
        await self.backend.stop_robot(robot)

    async def _lease(self, client: Client, command: Lease) -> None:
        identifier = f"{command.robot}/lease"
        self._require_operator(client, identifier, command.id)
        robot, holder = command.robot, self.leases.holder(command.robot)
        if command.action == "release":
            if holder != client.client_id:
                raise CommandRejected(
                    ErrorCode.LEASED, f"{identifier}: {robot} is not controlled by you (holder: {holder})", command.id
                )
            await self._halt(robot, f"{client.client_id} released it")
            self.leases.release(robot, client.client_id)
            self._lease_changed(robot, None, client.client_id, "released")
        elif holder is None or holder == client.client_id:
            self.leases.take(robot, client.client_id, time.monotonic())
            if holder is None:
                self._lease_changed(robot, client.client_id, None, "acquired")
        elif not command.force:
            raise CommandRejected(
                ErrorCode.LEASED,
                f"{identifier}: {robot} is controlled by {holder}; add force: true to take over",
                command.id,
            )
        else:
            await self._halt(robot, f"{client.client_id} takes over from {holder}")
            self.leases.take(robot, client.client_id, time.monotonic())
            self._lease_changed(robot, client.client_id, holder, "taken_over")
        self._reply(client, ack_message(command.id))

    async def _dispatch(self, client: Client, command: Command) -> None:
        now = time.monotonic()
        if isinstance(command, Ping):
            self._reply(client, pong_message(command.t, time.time()))
        elif isinstance(command, EStop):
            self._require_operator(client, "estop", command.id)
            await self.estop(command.robot, client.client_id)
            self._reply(client, ack_message(command.id))
        elif isinstance(command, CmdVel):
            await self._cmd_vel(client, command, now)
        elif isinstance(command, GoalPose):
            await self._goal(client, command)
        elif isinstance(command, Cancel):
            self._require_commandable(client, command.robot, f"{command.robot}/cancel", command.id)
            await self.backend.cancel(command.robot)
            self._reply(client, ack_message(command.id))
        elif isinstance(command, Playback):
            self._require_operator(client, f"playback/{command.action}", command.id)
            await self.backend.playback(command.action, command.value)
            self._reply(client, ack_message(command.id))
        elif isinstance(command, Stream):
            self._stream(client, command)
        elif isinstance(command, Lease):
            await self._lease(client, command)

    async def estop(self, robot: str | None, client_id: str | None) -> None:
        robots = [robot] if robot is not None else list(self._robots)
        for name in robots:
            self.deadman.release_robot(name)
            self.fleet.set_teleop(name, False)
        await asyncio.gather(*(self.backend.stop_robot(name) for name in robots))
        logger.warning("EMERGENCY STOP of %s by %s", ", ".join(robots), client_id)
        self.hub.broadcast_priority(encode(estop_message(robots, client_id)))
        for name in robots:
            self._publish_status(name)

    async def _cmd_vel(self, client: Client, command: CmdVel, now: float) -> None:
        robot = self._robots[command.robot]
        self._require_commandable(client, robot.name, f"{robot.name}/cmd_vel", command.id)
        clamped = clamp_velocity(command.linear, command.angular, robot.limits)
        previous = self.deadman.feed(robot.name, client.client_id, now)
        if previous is not None:
            # Control changed hands: the robot stops before the new operator's command applies.
            await self.backend.send_velocity(robot.name, 0.0, 0.0)
        first = self.fleet.status(robot.name, now)["mode"] != "teleop" or previous is not None
        if first:
            # Teleoperation overrides navigation.
            await self.backend.cancel(robot.name)
            self.fleet.set_teleop(robot.name, True)
            self._publish_status(robot.name)
        await self.backend.send_velocity(robot.name, clamped.linear, clamped.angular)
        if command.id is not None:
            self._reply(client, ack_message(command.id))

    async def _goal(self, client: Client, command: GoalPose) -> None:
        identifier = f"{command.robot}/goal_pose"
        self._require_commandable(client, command.robot, identifier, command.id)
        check_goal(command.robot, command.x, command.y, self.map_grid())
        if self.deadman.controller(command.robot) is not None:
            self.deadman.release_robot(command.robot)
            self.fleet.set_teleop(command.robot, False)
            await self.backend.send_velocity(command.robot, 0.0, 0.0)
        try:
            await self.backend.send_goal(command.robot, command.x, command.y, command.yaw)
        except CommandRejected as exc:
            exc.request_id = command.id
            raise
        self._publish_status(command.robot)
        self._reply(client, ack_message(command.id))

    async def _snapshot(self, client: Client, command: Snapshot) -> None:
        robot = self._robots[command.robot]
        camera = robot.camera(command.camera)
        if camera is None:
            what = f"no camera named {command.camera!r}" if command.camera else "no camera"
            raise CommandRejected(ErrorCode.NO_CAMERA, f"{robot.name}/snapshot: {robot.name} has {what}", command.id)
        frame = await self.backend.snapshot(robot.name, camera.name)
        if frame is None:
            raise CommandRejected(
                ErrorCode.NO_CAMERA,
                f"{robot.name}/snapshot: camera {camera.name!r} has produced no image yet; try again shortly",
                command.id,
            )
        client.channel.put_priority(self._encode_frame(frame, command.id), binary=True)
        self._reply(client, ack_message(command.id))

    def _stream(self, client: Client, command: Stream) -> None:
        robot = self._robots[command.robot]
        if robot.camera(command.camera) is None:
            raise CommandRejected(
                ErrorCode.NO_CAMERA,
                f"{robot.name}/stream: {robot.name} has no camera named {command.camera!r}",
                command.id,
            )
        identifier = f"{robot.name}/camera/{command.camera}"
        self.hub.set_stream(client.channel, identifier, command.fps)
        self._update_stream_demand(identifier)
        self._reply(client, ack_message(command.id))

    def _update_stream_demand(self, identifier: str) -> None:
        robot, _, camera = identifier.replace("/camera/", "/", 1).partition("/")
        spec = self._robots[robot].camera(camera)
        if spec is not None:
            self.backend.set_stream(robot, camera, min(spec.rate, self.hub.stream_demand(identifier)))

    def _encode_frame(self, frame: FrameEvent, request_id: RequestId | None) -> bytes:
        identifier = f"{frame.robot}/camera/{frame.camera}"
        seq = self._frame_seq.get(identifier, 0) + 1
        self._frame_seq[identifier] = seq
        header: FrameHeader = {
            "identifier": identifier,
            "seq": seq,
            "stamp": round(frame.stamp, 6),
            "encoding": "jpeg",
            "width": frame.width,
            "height": frame.height,
            "lens": lens_description(self._robots[frame.robot], frame.camera),
            "request_id": request_id,
        }
        return encode_frame(header, frame.jpeg)

    # -- backend events (always on the loop thread) -----------------------------------------------

    def on_event(self, event: Event) -> None:
        if isinstance(event, PlaybackEvent):
            self._playback = playback_message(
                position=event.position,
                duration=event.duration,
                rate=event.rate,
                paused=event.paused,
                loop=event.loop,
            )
            self.hub.publish_state("playback", encode(self._playback))
            return
        if isinstance(event, MapEvent):
            self._live_map = event.grid
            logger.info("map received: %dx%d cells, bounds %s", event.grid.width, event.grid.height, event.grid.bounds)
            if self.config.scene.url is None:
                # No hand-made twin: the map becomes one (built off the loop, once per map change).
                self._pending_map = event
                if self._twin_task is None or self._twin_task.done():
                    self._twin_task = asyncio.get_running_loop().create_task(self._build_twins(), name="map-twin")
            return
        if event.robot not in self._robots:
            logger.warning("backend reported unknown robot %r; ignored", event.robot)
            return
        if isinstance(event, RobotModelEvent):
            task = asyncio.get_running_loop().create_task(self._build_model(event), name=f"model-{event.robot}")
            self._model_tasks.add(task)
            task.add_done_callback(self._model_tasks.discard)
            return
        now = time.monotonic()
        if isinstance(event, PoseEvent):
            message = self.fleet.on_pose(event, now)
            self.hub.publish_state(message["identifier"], encode(message))
            if not self._was_online[event.robot]:
                self._publish_status(event.robot)
        elif isinstance(event, SensorEvent):
            sensor = self.fleet.on_sensor(event)
            if sensor is not None:
                self.hub.publish_state(f"{event.robot}/sensor/{event.name}", encode(sensor))
        elif isinstance(event, NavEvent):
            self.fleet.on_nav(event)
            self._publish_status(event.robot)
        elif isinstance(event, ScanEvent):
            scan = scan_message(
                event.robot,
                stamp=event.stamp,
                frame=event.frame,
                angle_min=event.angle_min,
                angle_increment=event.angle_increment,
                range_max=event.range_max,
                ranges=event.ranges,
            )
            self.hub.publish_state(scan["identifier"], encode(scan))
        elif isinstance(event, FrameEvent):
            identifier = f"{event.robot}/camera/{event.camera}"
            if self.hub.stream_demand(identifier) > 0:
                self.hub.publish_frame(identifier, self._encode_frame(event, None), now)

    async def _build_twins(self) -> None:
        """Turn the newest map into a twin, then the next one if another arrived meanwhile."""
        while self._pending_map is not None:
            event, self._pending_map = self._pending_map, None
            digest = hashlib.sha256(
                event.grid.occupied.tobytes()
                + (event.unknown.tobytes() if event.unknown is not None else b"")
                + repr(
                    (event.grid.origin_x, event.grid.origin_y, event.grid.resolution, event.grid.occupied.shape)
                ).encode()
            ).hexdigest()[:12]
            name = f"map-{digest}.glb"
            if name in self.generated:
                continue  # the same map again (a re-published latched /map): nothing to rebuild
            started = time.monotonic()
            try:
                glb = await asyncio.to_thread(grid_to_glb, event.grid, unknown=event.unknown)
            except ValueError as exc:
                logger.error("could not build a twin from the map: %s", exc)
                continue
            # Keep only the newest twin: clients that load it later must find it, older ones are stale.
            for old in [k for k in self.generated if k.startswith("map-")]:
                del self.generated[old]
            self.generated[name] = glb
            self.scene_url = f"{GENERATED_SCENES}/{name}"
            logger.info(
                "twin of the map built in %.2f s (%d kB): %s",
                time.monotonic() - started,
                len(glb) // 1024,
                self.scene_url,
            )
            self.hub.publish_state("scene", encode(scene_message(self.scene_url, self._map_to_scene())))

    async def _build_model(self, event: RobotModelEvent) -> None:
        """A robot's URDF becomes its glTF model (off the loop, once per distinct description)."""
        spec = self._robots[event.robot]
        digest = hashlib.sha256(event.urdf.encode()).hexdigest()[:12]
        name = f"robot-{event.robot}-{digest}.glb"
        if name in self.generated:
            return
        packages = list(spec.model_source.packages) if spec.model_source is not None else []
        namespace = spec.namespace.strip("/")
        glb = await asyncio.to_thread(
            robot_description_glb, event.urdf, packages, namespace=f"{namespace}/" if namespace else ""
        )
        for old in [k for k in self.generated if k.startswith(f"robot-{event.robot}-")]:
            del self.generated[old]
        self.generated[name] = glb
        url = f"{GENERATED_SCENES}/{name}"
        self.model_urls[event.robot] = url
        logger.info("model of %s from its robot_description: %s (%d kB)", event.robot, url, len(glb) // 1024)
        self.hub.broadcast_priority(encode(model_message(event.robot, url)))

    def _map_to_scene(self) -> Transform2D:
        m = self.config.scene.map_to_scene
        return {"x": m.x, "y": m.y, "z": m.z, "yaw": m.yaw}

    def _publish_status(self, robot: str) -> None:
        status = self.fleet.status(robot, time.monotonic())
        self._was_online[robot] = status["online"]
        self.hub.publish_state(status["identifier"], encode(status))

    async def _stop_robot(self, robot: str, reason: str) -> None:
        logger.info("stopping %s: %s", robot, reason)
        self.fleet.set_teleop(robot, False)
        try:
            await self.backend.send_velocity(robot, 0.0, 0.0)
        finally:
            self._publish_status(robot)

    async def _watch_backend(self, now: float) -> None:
        """Report a backend failure (and its end) to every client, and keep trying to recover."""
        failure = self.backend.failure
        if failure != self._reported_failure:
            self._reported_failure = failure
            if failure:
                logger.error("backend %s failed: %s", self.backend.name, failure)
            self.hub.broadcast_priority(encode(backend_message(self.backend.name, failure)))
        if failure and now >= self._next_recovery:
            self._next_recovery = now + RECOVERY_PERIOD
            try:
                await self.backend.recover()
            except Exception:
                logger.exception("backend %s could not recover; retrying in %.0f s", self.backend.name, RECOVERY_PERIOD)

    async def _tick(self) -> None:
        next_status = 0.0
        while True:
            await asyncio.sleep(DEADMAN_PERIOD)
            now = time.monotonic()
            for robot in self.deadman.expired(now):
                try:
                    await self._stop_robot(robot, "operator stopped sending cmd_vel (deadman)")
                except Exception:
                    # The ticker must outlive one failed stop, or no deadman would ever fire again.
                    logger.exception("deadman could not stop %s", robot)
            busy = self.fleet.busy()
            for robot in busy:
                self.leases.keep_alive(robot, now)
            for robot in self.leases.expired(now, busy):
                holder = self.fleet.status(robot, now)["controller"]
                try:
                    await self._halt(robot, "lease expired")
                except Exception:
                    logger.exception("could not stop %s when its lease expired", robot)
                self._lease_changed(robot, None, holder, "expired")
            for robot, was in self._was_online.items():
                if was != self.fleet.online(robot, now):
                    self._publish_status(robot)
            if now >= next_status:
                next_status = now + STATUS_PERIOD
                for robot in self._robots:
                    self._publish_status(robot)
                await self._watch_backend(now)
