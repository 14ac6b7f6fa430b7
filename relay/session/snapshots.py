"""Camera snapshots for clients, within the relay's budget (relay.session.budget): a picture now, or the budget's slot
for other work that takes one (a target from a robot's live image)."""

from __future__ import annotations

from collections.abc import Awaitable, Mapping

from ..backends.base import Backend
from ..config import Robot
from ..errors import CommandRejected, ProtocolError
from ..media.streams import CameraStreams
from ..station.outbox import Outbox
from ..wire.commands import Snapshot
from .budget import SnapshotBudget
from .clients import Client
from .protocol import ErrorCode, RequestId, robot_identifier


class Snapshots:
    def __init__(self, robots: Mapping[str, Robot], backend: Backend, streams: CameraStreams, outbox: Outbox) -> None:
        self.robots = robots
        self.backend = backend
        self.streams = streams
        self.outbox = outbox
        self.budget = SnapshotBudget()

    def admit(self, client: Client, identifier: str, request_id: RequestId, now: float) -> None:
        """A slot of the budget for this client, or ``busy`` naming the limit: rendering or waiting for a camera's
        next frame takes a while, and viewers must not keep every core busy."""
        refusal = self.budget.take(client.client_id, client.role, now)
        if refusal is not None:
            raise ProtocolError(ErrorCode.BUSY, f"{identifier}: refused: {refusal}", request_id)

    async def within(self, client: Client, work: Awaitable[None]) -> None:
        """Run ``work`` in the slot :meth:`admit` gave; the slot is free again when it ends, however it ends."""
        try:
            await work
        finally:
            self.budget.done(client.client_id, client.role)

    def forget(self, client_id: str) -> None:
        self.budget.forget(client_id)

    async def take(self, client: Client, command: Snapshot) -> None:
        """The camera's picture to this client (its frame on the priority lane), then the ``ack``."""
        robot = self.robots[command.robot]
        camera = robot.camera(command.camera)
        identifier = robot_identifier(robot.name, "snapshot")
        if camera is None:
            what = f"no camera named {command.camera!r}" if command.camera else "no camera"
            raise CommandRejected(ErrorCode.NO_CAMERA, f"{identifier}: {robot.name} has {what}", command.id)
        frame = await self.backend.snapshot(robot.name, camera.name)
        if frame is None:
            raise CommandRejected(
                ErrorCode.NO_CAMERA,
                f"{identifier}: camera {camera.name!r} has produced no image yet; try again shortly",
                command.id,
            )
        self.outbox.frame(client, self.streams.encode(frame, command.id))
        self.outbox.ack(client, command.id)
