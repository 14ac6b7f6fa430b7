"""Client frames in, through the rules, out to the backend: one ``ack`` or ``error`` for every command.

- every frame is parsed by ``relay.session.protocol``; a bad one gets exactly one ``error`` and changes nothing;
- every command with an ``id`` gets exactly one ``ack`` or ``error`` with that id, and is audited;
- velocities are clamped to the robot's limits, goals are checked against the map, and control changing hands
  stops the robot first (``relay.control.control``);
- ``estop`` is never rate-limited and is announced to every client ahead of anything else they have queued.

Nothing here reads a clock: the caller passes ``now`` (loop time, seconds), so the rules are tested without
sockets and without sleeping (tests/test_commands.py).
"""

from __future__ import annotations

import inspect
import logging
import time
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass

from ..arm.wire import ArmTwist
from ..backends.base import Backend
from ..config import Robot
from ..control.arm_control import ArmControl
from ..control.control import Control
from ..control.safety import check_goal, check_goal_clear, clamp_velocity
from ..errors import CommandRejected, ProtocolError
from ..fleet.latency import StageLatency
from ..fleet.occupancy import OccupancyGrid
from ..fleet.state import FleetState
from ..inspection.service import Inspection
from ..inspection.wire import MissionStart, TargetAdd
from ..media.streams import CameraStreams
from ..station.audit import CommandAudit
from ..station.messages import pong_message
from ..station.outbox import Outbox
from ..study.service import StudyService
from ..wire.commands import Cancel, CmdVel, EStop, GoalPose, Lease, Name, Ping, Playback, Snapshot, Stream
from ..wire.viewer import Viewer
from .clients import Client, roster
from .protocol import (
    ArmCommands,
    Command,
    ErrorCode,
    InspectionCommands,
    RequestId,
    StudyCommands,
    command_identifier,
    parse_command,
    robot_identifier,
)
from .snapshots import Snapshots

logger = logging.getLogger(__name__)


@dataclass
class CommandHandler:
    """Carries out client commands; its parts are the relay's (``relay.station.core`` builds them and this with
    them)."""

    robots: Mapping[str, Robot]
    backend: Backend
    fleet: FleetState
    control: Control
    streams: CameraStreams
    outbox: Outbox
    audit: CommandAudit
    map_grid: Callable[[], OccupancyGrid | None]
    inspection: Inspection
    #: Every connected client by id (relay.station.core's own dict): the names of the ``operators`` roster.
    clients: Mapping[str, Client]
    snapshots: Snapshots
    #: How late each robot's commands reach its backend (relay.fleet.latency), for /metrics.
    latency: StageLatency
    #: The arms' commands and deadman (relay.control.arm_control).
    arms: ArmControl
    study: StudyService  # relay.study.service: the study's commands
    wall_clock: Callable[[], float] = time.time

    def handle_binary(self, client: Client) -> None:
        self.outbox.error(client, None, ErrorCode.UNSUPPORTED, "binary frames from clients are not defined in v1")

    async def handle_text(
        self, client: Client, data: str | bytes, now: float, received: float | None = None, arrived: float | None = None
    ) -> None:
        """Handle one text frame, read from the connection at ``received`` (default ``now``), its bytes there since
        ``arrived`` at the latest (default ``received``; relay.net.loop_lag dates reads after a stall of the loop). Only
        unexpected failures propagate (the server then closes with 1011)."""
        received = now if received is None else received
        arrived = received if arrived is None else min(arrived, received)
        try:
            command = parse_command(data, self.robots)
        except ProtocolError as exc:
            # A frame that cannot be parsed spends the rate like any other: a flood of them must not fill the
            # audit log (the attack that rotated it away in seconds) nor the relay's time.
            if not client.allowance.take(now):
                self._rate_limited(client, exc.request_id, exc.identifier, None, now)
                return
            self.outbox.error(client, exc.request_id, exc.code, exc.message)
            self.audit.frame(client, exc.identifier, exc.request_id, None, exc)
            return
        request_id = getattr(command, "id", None)
        if not isinstance(command, EStop) and not client.allowance.take(now):
            # Dropped before it can reach a robot; an estop is never held back.
            self._rate_limited(client, request_id, command_identifier(command), command, now)
            return
        if isinstance(command, Viewer):  # checked, no reply, no audit; recorded (station/core.py), a study counts views
            self.study.events.viewed(client.client_id, command.view)
            return
        if isinstance(command, (Snapshot, *InspectionCommands, *StudyCommands)):
            self._run_apart_admitted(client, command, now)
            return
        if isinstance(command, GoalPose):
            # Planning takes a while too: the same client's estop, cancel or release must not wait behind it (an
            # estop was once acknowledged 16 s late). Anything that overtakes the goal supersedes it.
            client.spawn(self._run_apart(client, command, self._goal(client, command, now, arrived)))
            return
        if isinstance(command, ArmTwist) and command.moves:  # checked on a worker: apart too, a stop voids it
            client.spawn(self._run_apart(client, command, self.arms.handle(client, command, now, now - arrived)))
            return
        try:
            await self._dispatch(client, command, now, received, arrived)
        except ProtocolError as exc:
            exc.request_id = request_id if exc.request_id is None else exc.request_id
            self.outbox.error(client, exc.request_id, exc.code, exc.message)
            self.audit.command(client, command, exc)
            return
        self.audit.command(client, command, None)

    def _rate_limited(
        self, client: Client, request_id: RequestId | None, identifier: str | None, command: Command | None, now: float
    ) -> None:
        """Refuse a frame over the client's rate. Its audit record is budgeted like every refusal (relay.station.audit),
        so that a flood cannot rotate the real records away."""
        says = f"more than {client.allowance.rate:g} messages a second; this one was dropped"
        error = ProtocolError(ErrorCode.RATE_LIMITED, says, request_id)
        self.outbox.error(client, request_id, error.code, error.message)
        if command is not None:
            self.audit.command(client, command, error)
        else:
            self.audit.frame(client, identifier, request_id, None, error)

    def _run_apart_admitted(self, client: Client, command: Command, now: float) -> None:
        """Snapshots, the inspection and study commands take a while (rendering, waiting for a camera's next frame,
        planning every step of a mission, segmenting a region, placing a study task's robots): they run beside the
        client's later frames (an estop among them), and what takes a picture spends the snapshots' budget."""
        work: Awaitable[None]
        if isinstance(command, Snapshot):
            work = self.snapshots.take(client, command)
        elif isinstance(command, StudyCommands):  # a task's start waits for its robots to be placed
            work = self.study.handle(client, command, now)
        else:
            work = self._inspection(client, command, now)
        if isinstance(command, Snapshot) or (isinstance(command, TargetAdd) and command.robot is not None):
            try:
                self.snapshots.admit(client, command.identifier, command.id, now)
            except ProtocolError as exc:
                if inspect.iscoroutine(work):
                    work.close()
                self.outbox.error(client, exc.request_id, exc.code, exc.message)
                self.audit.command(client, command, exc)
                return
            work = self.snapshots.within(client, work)
        client.spawn(self._run_apart(client, command, work))

    async def _inspection(self, client: Client, command: Command, now: float) -> None:
        if isinstance(command, MissionStart):
            self.control.gate.require_record("mission/start", command.id)
        await self.inspection.handle(client, command, now)
        self.outbox.ack(client, getattr(command, "id"))  # noqa: B009 - every inspection command has an id

    async def _run_apart(self, client: Client, command: Command, work: Awaitable[None]) -> None:
        """A command that runs beside the client's later frames: its reply and audit record come when it ends."""
        try:
            await work
        except ProtocolError as exc:
            exc.request_id = getattr(command, "id", None) if exc.request_id is None else exc.request_id
            self.outbox.error(client, exc.request_id, exc.code, exc.message)
            self.audit.command(client, command, exc)
        except Exception:
            request_id = getattr(command, "id", None)
            logger.exception("command %r of client %s failed", request_id, client.client_id)
            self.outbox.error(client, request_id, ErrorCode.INTERNAL, "the relay failed on this command; see its log")
        else:
            self.audit.command(client, command, None)

    async def _dispatch(self, client: Client, command: Command, now: float, received: float, arrived: float) -> None:
        if isinstance(command, Ping):
            self.outbox.to(client, pong_message(command.t, self.wall_clock()))
        elif isinstance(command, EStop):
            await self._estop(client, command, now)
        elif isinstance(command, CmdVel):
            await self._cmd_vel(client, command, now, received, arrived)
        elif isinstance(command, ArmCommands):
            # Its age as a cmd_vel's without a client stamp: since the relay read it, or since a stall began.
            await self.arms.handle(client, command, now, now - arrived)
        elif isinstance(command, Cancel):
            self.control.gate.require_commandable(
                client, command.robot, robot_identifier(command.robot, "cancel"), command.id, now
            )
            self.control.supersede(command.robot)
            await self.backend.cancel(command.robot)
            self.outbox.ack(client, command.id)
        elif isinstance(command, Playback):
            self.control.gate.require(client, "drive", f"playback/{command.action}", command.id)
            await self.backend.playback(command.action, command.value)
            self.outbox.ack(client, command.id)
        elif isinstance(command, Stream):
            self.streams.set(client.channel, command)
            self.outbox.ack(client, command.id)
        elif isinstance(command, Lease):
            await self.control.lease(client, command, now)
            self.outbox.ack(client, command.id)
        elif isinstance(command, Name):
            if client.user is not None:
                raise ProtocolError(
                    ErrorCode.FORBIDDEN, f"name: signed in as {client.user}, the account's name is yours", command.id
                )
            client.name = command.name
            self.outbox.ack(client, command.id)
            self.outbox.operators(roster(self.clients))
        else:
            # A declared command with no handler here would otherwise go unanswered.
            raise ProtocolError(ErrorCode.INTERNAL, f"{command.identifier}: this relay carries out no such command")

    async def _estop(self, client: Client, command: EStop, now: float) -> None:
        resets = command.action == "reset"
        self.control.gate.require(client, "reset" if resets else "stop", "estop", command.id)
        if resets:
            refusal = self.control.reset_refusal(command.robot, client.user or client.client_id, client.role == "admin")
            if refusal is not None:
                raise ProtocolError(ErrorCode.FORBIDDEN, f"estop: {refusal}", command.id)
            self.control.reset_estop(command.robot, client.client_id, now)
            self.outbox.ack(client, command.id)
            return
        failed = await self.control.estop(command.robot, client.client_id, now, who=client.user, label=client.name)
        if failed:
            # The robots that could be reached are stopped; the operator must learn at once which were not.
            reasons = "; ".join(f"{robot}: {exc!r}" for robot, exc in failed.items())
            raise ProtocolError(
                ErrorCode.INTERNAL,
                f"estop: {', '.join(failed)} could not be stopped ({reasons}); every other robot was stopped",
                command.id,
            )
        self.outbox.ack(client, command.id)

    async def _cmd_vel(self, client: Client, command: CmdVel, now: float, received: float, arrived: float) -> None:
        robot = self.robots[command.robot]
        identifier = robot_identifier(robot.name, "cmd_vel")
        # Its age: the time since the relay read it, plus, when the client stamps its commands, how much longer
        # than its quickest recent command it took to reach the relay (relay.session.freshness).
        age = now - received
        if command.sent is not None:
            # Fed the read time, not the earlier arrival date: a date before the client's send would teach its
            # clock estimate an impossible delay, and every later command would look stale.
            age += client.sender_clock.age(command.sent, received)
        age = max(age, now - arrived)  # both are lower bounds of how long it waited
        self.latency.took(robot.name, "command", age)
        self.control.gate.admit(client, robot.name, identifier, command.id, now, age)
        clamped = clamp_velocity(command.linear, command.angular, robot.limits)
        previous = self.control.deadman.feed(robot.name, client.client_id, now)
        if previous is not None:
            # Control changed hands: the robot stops before the new operator's command applies.
            await self.backend.send_velocity(robot.name, 0.0, 0.0)
        if self.fleet.status(robot.name, now)["mode"] != "teleop" or previous is not None:
            # Teleoperation overrides navigation, also a goal still being planned.
            self.control.supersede(robot.name)
            await self.backend.cancel(robot.name)
            self.fleet.set_teleop(robot.name, True)
            self.outbox.status(robot.name, now)
        stamp = self.wall_clock() - age  # when the operator's command reached the relay, for a robot's watchdog
        await self.backend.send_velocity(robot.name, clamped.linear, clamped.angular, stamp=stamp)
        if command.id is not None:
            self.outbox.ack(client, command.id)

    async def _goal(self, client: Client, command: GoalPose, now: float, arrived: float) -> None:
        identifier = robot_identifier(command.robot, "goal_pose")
        self.control.gate.admit(client, command.robot, identifier, command.id, now, now - arrived)
        check_goal(command.robot, command.x, command.y, self.map_grid())
        check_goal_clear(command.robot, command.x, command.y, self.fleet.positions(now))
        if self.control.deadman.controller(command.robot) is not None:
            self.control.deadman.release_robot(command.robot)
            self.fleet.set_teleop(command.robot, False)
            await self.backend.send_velocity(command.robot, 0.0, 0.0)
        generation = self.control.supersede(command.robot)
        try:
            await self.backend.send_goal(
                command.robot,
                command.x,
                command.y,
                command.yaw,
                current=lambda: self.control.generation(command.robot) == generation,
            )
        except CommandRejected as exc:
            exc.request_id = command.id
            raise
        if self.control.generation(command.robot) != generation:
            raise CommandRejected(
                ErrorCode.SUPERSEDED,
                f"{identifier}: dropped: an emergency stop, a take-over, a cancel or a newer goal for "
                f"{command.robot} came while it was being planned",
                command.id,
            )
        self.outbox.status(command.robot, now)
        self.outbox.ack(client, command.id)
