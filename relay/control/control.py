"""Who may move a robot, and every path that stops one: the rules, with the time passed in.

``Control`` owns the lease table and the deadman and carries out their decisions on the backend: a robot is
stopped when its operator falls silent or disconnects, before a lease changes hands, and on an emergency stop.
Every command that moves a robot passes the motion gate (``Control.gate``, relay/control/motion_gate.py) once, before
anything reaches the robot. An emergency stop latches: the robots it stopped refuse every motion command
(``estopped``) until an operator resets it.

When the backend reaches other relays serving the same robots (``Backend.fleet_peer``, relay/control/fleet_peer.py), an
estop made here is sent to them and theirs latch here, and a robot whose lease is held through another relay
refuses this relay's commands. A reset lifts only this relay's latch: the operators of each relay reset their own.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence

from ..backends.base import Backend
from ..errors import CommandRejected
from ..fleet.state import FleetState
from ..session.clients import Client
from ..session.protocol import ErrorCode, robot_identifier
from ..station.messages import LeaseReason
from ..station.outbox import Outbox
from ..wire.commands import Lease
from .fleet_peer import FleetPeer
from .leases import LeaseTable
from .motion_gate import MotionGate, Record
from .safety import Deadman, reset_refusal
from .stop_notices import StopNotices

logger = logging.getLogger(__name__)

#: Who latched an estop that the relay learned from a robot's watchdog (``estop.by``, ``status`` of the refusal).
WATCHDOG = "the robot's watchdog"


class Control:
    def __init__(
        self,
        robots: Sequence[str],
        backend: Backend,
        fleet: FleetState,
        outbox: Outbox,
        record: Record,
        stops: StopNotices,
        *,
        deadman_timeout: float,
        lease_timeout: float,
        clock: Callable[[], float] = time.monotonic,
        estop_reset: str = "anyone",
    ) -> None:
        self.robots = list(robots)
        #: robots.yaml's safety.estop_reset: "anyone" whose role may, or only the "presser" (and admins).
        self.estop_reset = estop_reset
        #: Who pressed each latched robot's estop: the account, or the client id of a client without one.
        self.pressers: dict[str, str] = {}
        self.backend = backend
        self.fleet = fleet
        self.outbox = outbox
        self.deadman = Deadman(deadman_timeout)
        self.leases = LeaseTable(lease_timeout)
        #: Robots whose emergency stop is latched, and who latched it.
        self.latched: dict[str, str | None] = {}
        #: Per robot, a number that every stop and every new goal bumps: work that finishes for an older
        #: number (a goal still being planned when the estop came) is dropped.
        self._generation: dict[str, int] = {}
        #: Told of every stop of a robot by these rules: missions pause or abort, and keep their robots' leases.
        self.stops = stops
        self.clock = clock
        #: Other relays of the same fleet (None: this relay is alone, or its backend cannot reach them).
        self.peer: FleetPeer | None = backend.fleet_peer()
        self._remote_stops: set[asyncio.Task[dict[str, BaseException]]] = set()
        #: The one way in for every command that moves a robot (relay/control/motion_gate.py).
        self.gate = MotionGate(backend, self.peer, record, self.latched, self.deadman, self.leases, self.lease_changed)
        if self.peer is not None:
            self.peer.attach(self._remote_estop, self._remote_lease)

    def generation(self, robot: str) -> int:
        return self._generation.get(robot, 0)

    def supersede(self, robot: str) -> int:
        """Whatever the robot was asked to do before is void; returns the new generation."""
        self._generation[robot] = self.generation(robot) + 1
        return self._generation[robot]

    # -- stops ------------------------------------------------------------------------------------

    async def stop_teleop(self, robot: str, reason: str, now: float) -> None:
        """Zero velocity for a robot whose teleoperation ended (deadman, disconnect); its goal is not touched."""
        logger.info("stopping %s: %s", robot, reason)
        self.fleet.set_teleop(robot, False)
        try:
            await self.backend.send_velocity(robot, 0.0, 0.0)
        finally:
            self.outbox.status(robot, now)

    async def halt(self, robot: str, reason: str) -> None:
        """Zero velocity and no goal: before a lease changes hands."""
        logger.info("stopping %s: %s", robot, reason)
        self.supersede(robot)
        self.deadman.release_robot(robot)
        self.fleet.set_teleop(robot, False)
        # Its mission learns first why the robot stops, so that the goal's cancellation the stop causes reads as
        # this stop, not as a goal that failed.
        self.stops.stopped(robot, reason, estop=False)
        await self.backend.stop_robot(robot)

    async def estop(
        self,
        robot: str | None,
        by: str | None,
        now: float,
        *,
        remote: bool = False,
        who: str | None = None,
        label: str | None = None,
    ) -> dict[str, BaseException]:
        """Stop ``robot`` (or every robot) at once; returns the robots whose stop failed, with why. Unless the
        estop came from another relay (``remote``), every other relay of the fleet is told to stop too.

        Every robot that can be reached is stopped even when another's stop raises: one broken robot must not
        keep the rest of the fleet moving. The ``estop`` broadcast names the robots that were stopped. ``who``: the
        presser's account (default ``by``), for ``safety.estop_reset: presser``; ``label``: how the missions it
        holds name the presser (their name; default ``by``).
        """
        robots = [robot] if robot is not None else list(self.robots)
        for name in robots:
            # Latched first: a command handled while the stops are under way is already refused.
            self.latched[name] = by
            if who or by:
                self.pressers[name] = who or by or ""
            self.supersede(name)
            self.fleet.set_estopped(name, True)
            self.deadman.release_robot(name)
            self.fleet.set_teleop(name, False)
            self.stops.stopped(name, f"emergency stop by {label or by}", estop=True)  # returns at once (see halt)
        if self.peer is not None and not remote:
            try:
                self.peer.estop(robot, by)
            except Exception:
                # This relay's own robots stop whatever happens to the message for the others.
                logger.exception("could not send the emergency stop to the other relays")
        results = await asyncio.gather(*(self.backend.estop_robot(name) for name in robots), return_exceptions=True)
        failed = {name: r for name, r in zip(robots, results, strict=True) if isinstance(r, BaseException)}
        stopped = [name for name in robots if name not in failed]
        logger.warning("EMERGENCY STOP of %s by %s", ", ".join(stopped) or "no robot", by)
        for name, exc in failed.items():
            logger.error("EMERGENCY STOP of %s by %s FAILED: %r", name, by, exc)
        self.outbox.estop(stopped, by)
        for name in robots:
            self.outbox.status(name, now)
        return failed

    def _remote_estop(self, robot: str | None, by: str | None) -> None:
        """An estop made on another relay (on the loop): latched and carried out here like our own."""
        if robot is not None and robot not in self.robots:
            logger.warning("an emergency stop from another relay names %r, which this relay does not serve", robot)
            return
        task = asyncio.get_running_loop().create_task(self.estop(robot, by, self.clock(), remote=True))
        self._remote_stops.add(task)
        task.add_done_callback(self._remote_stops.discard)

    def _remote_lease(self, robot: str, holder: str | None) -> None:
        """Another relay's operator took or left ``robot``: every client here sees who controls it."""
        if robot not in self.robots:
            return
        local = self.leases.holder(robot)
        self.fleet.set_controller(robot, local if local is not None else holder)
        self.outbox.status(robot, self.clock())

    def watchdog_estop(self, robot: str, now: float) -> None:
        """The robot's watchdog reports an estop latched on the robot (a relay before this one latched it): this
        relay latches it too and says by whom; the operator's reset lifts both."""
        if robot not in self.robots or robot in self.latched:
            return
        logger.warning("%s is emergency-stopped by its watchdog", robot)
        # As another relay's estop: carried out here, not sent on to the other relays (they hear the watchdog too).
        task = asyncio.get_running_loop().create_task(self.estop(robot, WATCHDOG, now, remote=True))
        self._remote_stops.add(task)
        task.add_done_callback(self._remote_stops.discard)

    def reset_refusal(self, robot: str | None, who: str, admin: bool) -> str | None:
        """Why ``who`` may not reset ``robot``'s estop (or every latched one's), or None (relay/control/safety.py)."""
        return reset_refusal(self.estop_reset, self.pressers, self.latched, robot, who, admin)

    def reset_estop(self, robot: str | None, by: str | None, now: float) -> list[str]:
        """Lift the latch of ``robot`` (or of every robot); they stay stopped until commanded. Returns them."""
        released = [robot] if robot is not None else list(self.latched)
        for name in released:
            self.latched.pop(name, None)
            self.pressers.pop(name, None)
            self.fleet.set_estopped(name, False)
            try:
                self.backend.release_estop(name)
            except Exception:
                logger.exception("could not lift the watchdog's latch of %s", name)
        logger.warning("emergency stop of %s reset by %s", ", ".join(released) or "no robot", by)
        self.outbox.estop(released, by, latched=False)
        for name in released:
            self.outbox.status(name, now)
        return released

    async def stop_all(self, reason: str) -> None:
        """Stop every robot (shutdown); a failure is logged and does not keep the others from stopping."""
        for robot in self.robots:
            self.deadman.release_robot(robot)
            self.fleet.set_teleop(robot, False)
        results = await asyncio.gather(*(self.backend.stop_robot(r) for r in self.robots), return_exceptions=True)
        for robot, result in zip(self.robots, results, strict=True):
            if isinstance(result, BaseException):
                logger.error("could not stop %s (%s): %r", robot, reason, result)
        logger.info("all robots stopped (%s)", reason)

    async def client_gone(self, client_id: str, now: float) -> None:
        """Robots the client was driving stop, then its leases end and the robots it had sent somewhere stop."""
        for robot in self.deadman.release_client(client_id):
            await self.stop_teleop(robot, f"operator {client_id} disconnected", now)
        # Nobody is watching a robot whose lease holder left: it stops too.
        for robot in self.leases.release_client(client_id):
            await self.halt(robot, f"lease holder {client_id} disconnected")
            self.lease_changed(robot, None, client_id, "disconnected", now)

    # -- leases -----------------------------------------------------------------------------------

    def lease_changed(
        self, robot: str, holder: str | None, previous: str | None, reason: LeaseReason, now: float
    ) -> None:
        logger.info("lease of %s: %s -> %s (%s)", robot, previous, holder, reason)
        self.fleet.set_controller(robot, holder)
        if self.peer is not None:
            try:
                self.peer.lease_changed(robot, holder)
            except Exception:
                logger.exception("could not tell the other relays that %s's lease is now %s's", robot, holder)
        self.outbox.lease(robot, holder, previous, reason)
        self.outbox.status(robot, now)

    async def lease(self, client: Client, command: Lease, now: float) -> None:
        """``<robot>/lease``: acquire, release, or take over with ``force``; raises when refused."""
        identifier = robot_identifier(command.robot, "lease")
        self.gate.require(client, "drive", identifier, command.id)
        robot, holder = command.robot, self.leases.holder(command.robot)
        if command.action == "release":
            if holder != client.client_id:
                raise CommandRejected(
                    ErrorCode.LEASED, f"{identifier}: {robot} is not controlled by you (holder: {holder})", command.id
                )
            await self.halt(robot, f"{client.client_id} released it")
            self.leases.release(robot, client.client_id)
            self.lease_changed(robot, None, client.client_id, "released", now)
        elif holder is None or holder == client.client_id:
            self.gate.refuse_if_held_elsewhere(robot, identifier, command.id)
            self.leases.take(robot, client.client_id, now)
            if holder is None:
                self.lease_changed(robot, client.client_id, None, "acquired", now)
        elif not command.force:
            raise CommandRejected(
                ErrorCode.LEASED,
                f"{identifier}: {robot} is controlled by {holder}; add force: true to take over",
                command.id,
            )
        else:
            self.gate.refuse_if_held_elsewhere(robot, identifier, command.id)
            await self.halt(robot, f"{client.client_id} takes over from {holder}")
            self.leases.take(robot, client.client_id, now)
            self.lease_changed(robot, client.client_id, holder, "taken_over", now)

    async def expire(self, now: float) -> None:
        """The deadman's and the leases' timeouts: silent operators' robots stop, idle leases end."""
        for robot in self.deadman.expired(now):
            try:
                await self.stop_teleop(robot, "operator stopped sending cmd_vel (deadman)", now)
            except Exception:
                # The ticker must outlive one failed stop, or no deadman would ever fire again.
                logger.exception("deadman could not stop %s", robot)
        busy = self.fleet.busy() | self.stops.held()
        for robot in busy:
            self.leases.keep_alive(robot, now)
        for robot in self.leases.expired(now, busy):
            holder = self.fleet.status(robot, now)["controller"]
            try:
                await self.halt(robot, "lease expired")
            except Exception:
                logger.exception("could not stop %s when its lease expired", robot)
            self.lease_changed(robot, None, holder, "expired", now)
