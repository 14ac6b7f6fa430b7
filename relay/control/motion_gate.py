"""The motion gate: every command that moves a robot passes here once, before anything reaches the robot.

It holds the rules of who may move a robot now (an operator, a fresh command, a relay that keeps its record, a
live robot, no latched estop, the robot's lease), not the stops: relay.control.control owns those, and latches the
estops this refuses motion under.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol

from ..accounts.roles import WHAT, Permission, may
from ..backends.base import Backend
from ..errors import CommandRejected, ProtocolError
from ..session.clients import Actor, Client
from ..session.protocol import ErrorCode, RequestId
from ..station.messages import LeaseReason
from .fleet_peer import FleetPeer
from .leases import LeaseTable
from .safety import Deadman


class Record(Protocol):
    """The record of who did what (relay.station.audit.CommandAudit): a relay that cannot keep it moves no robot."""

    @property
    def failure(self) -> str | None: ...


class MotionGate:
    def __init__(
        self,
        backend: Backend,
        peer: FleetPeer | None,
        record: Record,
        latched: Mapping[str, str | None],
        deadman: Deadman,
        leases: LeaseTable,
        acquired: Callable[[str, str | None, str | None, LeaseReason, float], None],
    ) -> None:
        """``latched``: the robots whose estop is latched, and by whom (relay.control.control's own table);
        ``acquired``: told when a command takes a free lease (robot, holder, previous, reason, now)."""
        self.backend = backend
        self.peer = peer
        self.record = record
        self.latched = latched
        self.deadman = deadman
        self.leases = leases
        self.acquired = acquired

    # -- the gate ----------------------------------------------------------------------------

    def admit(
        self, client: Client, robot: str, identifier: str, request_id: RequestId | None, now: float, age: float
    ) -> None:
        """The motion gate: a command that moves ``robot`` passes here once, before anything reaches the robot.
        Refused, in this order: from a viewer (``forbidden``); older than the deadman's timeout when the relay got
        to it (``stale``: a frozen or starved relay must not replay what the deadman already stopped); while the
        relay cannot keep its record (``audit_unavailable``); for a recording; while an estop is latched; while
        another operator holds the robot's lease (a free lease is taken)."""
        self.require(client, "drive", identifier, request_id)  # a viewer hears "forbidden", nothing else
        timeout = self.deadman.timeout
        if age > timeout:
            raise CommandRejected(
                ErrorCode.STALE,
                f"{identifier}: dropped: {age:.2f} s old when the relay got to it, more than the deadman's "
                f"{timeout:g} s; nothing reached the robot",
                request_id,
            )
        self.require_record(identifier, request_id)
        self.require_commandable(client, robot, identifier, request_id, now, moves=True)

    def require_record(self, identifier: str, request_id: RequestId | None) -> None:
        """A relay that cannot keep its record moves no robot (stops, estop included, still go through)."""
        failure = self.record.failure
        if failure is not None:
            raise CommandRejected(ErrorCode.AUDIT_UNAVAILABLE, f"{identifier}: refused: {failure}", request_id)

    # -- its parts ---------------------------------------------------------------------------------

    @staticmethod
    def require(client: Actor, permission: Permission, identifier: str, request_id: RequestId | None) -> None:
        """Refuse with ``forbidden`` what the client's role may not do (relay/accounts/roles.py)."""
        if not may(client.role, permission):
            article = "an" if client.role[0] in "aeiou" else "a"
            raise ProtocolError(
                ErrorCode.FORBIDDEN, f"{identifier}: {article} {client.role} cannot {WHAT[permission]}", request_id
            )

    def require_commandable(
        self,
        client: Actor,
        robot: str,
        identifier: str,
        request_id: RequestId | None,
        now: float,
        *,
        moves: bool = False,
        permission: Permission = "drive",
    ) -> None:
        """The role's ``permission`` (an inspector's missions: ``inspect``), a robot that is not a recording, no
        latched estop when the command ``moves`` the robot, and the robot's lease (taken when free)."""
        self.require_movable(client, robot, identifier, request_id, moves=moves, permission=permission)
        self.refuse_if_held_elsewhere(robot, identifier, request_id)
        allowed, before = self.leases.use(robot, client.client_id, now)
        if not allowed:
            raise CommandRejected(
                ErrorCode.LEASED,
                f"{identifier}: {robot} is controlled by {before}; send {robot}/lease with force: true to take over",
                request_id,
            )
        if before is None:
            self.acquired(robot, client.client_id, None, "acquired", now)

    def require_movable(
        self,
        client: Actor,
        robot: str,
        identifier: str,
        request_id: RequestId | None,
        *,
        moves: bool = True,
        permission: Permission = "drive",
    ) -> None:
        """Every rule of :meth:`require_commandable` but the lease: for what acts through a lease it does not hold
        (an operator resuming a mission that holds the robot)."""
        self.require(client, permission, identifier, request_id)
        refusal = self.backend.command_refusal(robot)
        if refusal is not None:
            raise CommandRejected(ErrorCode.RECORDING, f"{identifier}: {refusal}", request_id)
        if moves and robot in self.latched:
            by = self.latched[robot]
            raise CommandRejected(
                ErrorCode.ESTOPPED,
                f"{identifier}: {robot} is emergency-stopped{f' by {by}' if by else ''}; "
                "an operator must reset it first (estop with action: reset)",
                request_id,
            )

    def refuse_if_held_elsewhere(self, robot: str, identifier: str, request_id: RequestId | None) -> None:
        lease = self.peer.held_elsewhere(robot) if self.peer is not None else None
        if lease is not None:
            raise CommandRejected(
                ErrorCode.LEASED,
                f"{identifier}: {robot} is controlled by {lease.holder} {lease.lapse()}; "
                "it must be released there (or that relay stop)",
                request_id,
            )
