"""A relay without sockets for the command tests: its backend faked and recording, each client's transport recording
what it got, a clock moved by hand."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import orjson

from relay.arm.named import JointGoal
from relay.backends.base import Backend, Vec3
from relay.config import FleetConfig
from relay.fleet.events import EventSink, FrameEvent
from relay.station.core import Relay
from relay.station.messages import decode_frame

Call = tuple[Any, ...]


class FakeBackend(Backend):
    """Records every command; ``broken`` robots raise on stop, as a robot whose driver hangs up would."""

    name: ClassVar[str] = "fake"

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        super().__init__(config, sink)
        self.calls: list[Call] = []
        self.broken: set[str] = set()
        self.frame: FrameEvent | None = None
        #: When set, goals are "planned" until the test sets it (a slow A* in a worker, as the sim does).
        self.planning: asyncio.Event | None = None
        self.stamps: list[float | None] = []  # of each velocity: when the operator's command reached the relay
        self.arm_calls: list[Call] = []  # apart from ``calls``: every stop of a robot stops its arm too

    async def start(self) -> None:
        self.calls.append(("start",))

    async def stop(self) -> None:
        self.calls.append(("stop",))

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        self.calls.append(("velocity", robot, linear, angular))
        self.stamps.append(stamp)

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        if self.planning is not None:
            await self.planning.wait()
        if current():  # what the sim does: a superseded plan is never followed
            self.calls.append(("goal", robot, x, y, yaw))

    async def cancel(self, robot: str) -> None:
        self.calls.append(("cancel", robot))

    async def stop_robot(self, robot: str) -> None:
        if robot in self.broken:
            raise ConnectionError(f"{robot}'s motor driver does not answer")
        await super().stop_robot(robot)

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        return self.frame

    async def send_arm_twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        self.arm_calls.append(("arm_twist", robot, linear, angular))

    async def send_arm_pose(self, robot: str, pose: str, goal: JointGoal) -> None:
        self.arm_calls.append(("arm_pose", robot, pose, goal))

    async def send_gripper(self, robot: str, command: str | float, position: float) -> None:
        self.arm_calls.append(("gripper", robot, command, position))

    async def stop_arm(self, robot: str) -> None:
        self.arm_calls.append(("arm_stop", robot))

    def arm_moves(self, robot: str) -> list[Call]:
        """The arm commands and stops ``robot`` received, in order."""
        return [c for c in self.arm_calls if c[1] == robot]

    def moves(self, robot: str) -> list[Call]:
        """The velocities and goals ``robot`` received, in order."""
        return [c for c in self.calls if c[0] in ("velocity", "goal") and c[1] == robot]


@dataclass
class RecordingTransport:
    """What one client received, decoded; ``closed`` is the close code if the relay closed it."""

    texts: list[dict[str, Any]] = field(default_factory=list)
    frames: list[tuple[dict[str, Any], bytes]] = field(default_factory=list)
    closed: int | None = None

    async def send_text(self, data: bytes) -> None:
        self.texts.append(orjson.loads(data))

    async def send_binary(self, data: bytes) -> None:
        self.frames.append(decode_frame(data))

    async def close(self, code: int, reason: str) -> None:
        self.closed = code

    def of(self, identifier: str) -> list[dict[str, Any]]:
        return [m for m in self.texts if m["identifier"] == identifier]

    def replies(self, request_id: object) -> list[dict[str, Any]]:
        return [m for m in self.texts if m["identifier"] in ("ack", "error") and m.get("id") == request_id]


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


@dataclass
class Station:
    relay: Relay
    backend: FakeBackend
    clock: Clock

    def connect(self, role: str = "operator") -> tuple[Any, RecordingTransport]:
        transport = RecordingTransport()
        client = self.relay.connect(transport, role=role)  # type: ignore[arg-type]
        return client, transport

    async def send(
        self, client: Any, message: dict[str, Any], *, apart: bool = True, received: float | None = None
    ) -> None:
        """``received``: when the frame was read from the connection (default now)."""
        await self.relay.handle_text(client, orjson.dumps(message), received)
        await self.settle(apart=apart)

    async def tick(self, seconds: float) -> None:
        self.clock.now += seconds
        await self.relay.supervisor.tick(self.clock.now)
        await self.settle()

    async def settle(self, *, apart: bool = True) -> None:
        """Let the hub's writers (and, with ``apart``, commands running apart: snapshots, goals) finish:
        scheduling, no timing."""
        for _ in range(200):
            tasks = [t for c in self.relay._clients.values() for t in c.tasks] if apart else []
            busy = any(c.queued for c in self.relay.hub) or tasks
            if not busy:
                # One more turn: a writer that just took the last item may still be in its send.
                await asyncio.sleep(0)
                return
            if tasks:
                # Some wait on a worker thread (an arm twist's check): loop turns alone do not finish them.
                await asyncio.wait(tasks, timeout=10.0)
            await asyncio.sleep(0)
        raise AssertionError("the relay did not settle in 200 loop turns")
