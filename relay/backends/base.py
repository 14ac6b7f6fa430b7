"""The one small interface every backend implements; everything above it is backend-agnostic."""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import ClassVar

from ..arm.named import JointGoal
from ..config import FleetConfig
from ..control.fleet_peer import FleetPeer
from ..errors import CommandRejected
from ..fleet.events import EventSink, FrameEvent
from ..fleet.occupancy import OccupancyGrid
from ..session.protocol import ErrorCode

Vec3 = tuple[float, float, float]


class Backend(abc.ABC):
    """A source of robot events and a sink of robot commands.

    Methods are called on the event loop. Commands are already validated and clamped by the relay; a backend
    raises :class:`~relay.errors.CommandRejected` for what only it can know (no path to a goal, a robot that is
    a recording). ``stop`` must leave every robot stopped.
    """

    name: ClassVar[str]

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        self.config = config
        self.sink = sink
        #: Why the backend is not working right now (None: it is); the relay reports it and calls ``recover``.
        self.failure: str | None = None

    @abc.abstractmethod
    async def start(self) -> None: ...

    @abc.abstractmethod
    async def stop(self) -> None: ...

    @abc.abstractmethod
    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        """Command a velocity. ``stamp`` is the wall-clock time the operator's command reached the relay (None: a
        stop of the relay's own, or now); a backend that hands commands to a watchdog stamps them with it."""

    @abc.abstractmethod
    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        """Navigate to the goal. ``current()`` turns False when the goal was superseded while the backend was
        still working on it (an estop, a take-over, a cancel or a newer goal came meanwhile): a backend that
        plans before it moves checks it before the robot follows anything."""

    @abc.abstractmethod
    async def cancel(self, robot: str) -> None:
        """Stop navigating (the robot stops where it is)."""

    async def stop_robot(self, robot: str) -> None:
        """Zero velocity, no goal and a still arm: what a take-over, a lease's end, a mission's pause, an estop and
        shutdown use."""
        await self.cancel(robot)
        await self.send_velocity(robot, 0.0, 0.0)
        await self.stop_arm(robot)

    # -- an arm (issue #32; relay/control/arm_control.py checks every command before it comes here) ------------

    async def send_arm_twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        """The arm's tip at this velocity (m/s, rad/s, in the arm's base link), until the next twist or a stop.
        Raises CommandRejected (``arm_refused``) with the robot side's reason when it refuses."""
        raise CommandRejected(ErrorCode.NO_ARM, f"{robot}/arm/twist: the {self.name} backend moves no arm")

    async def send_arm_pose(self, robot: str, pose: str, goal: JointGoal) -> None:
        """Move the arm to a named pose (its SRDF's group state): ``goal`` is its joints as the relay resolved them,
        and the time the slowest takes at a named pose's speed. CommandRejected says why not."""
        raise CommandRejected(ErrorCode.NO_ARM, f"{robot}/arm/pose: the {self.name} backend moves no arm")

    async def send_gripper(self, robot: str, command: str | float, position: float) -> None:
        """Open or close the gripper (``"open"``, ``"close"``) or move it to a position: ``position`` is the
        gripper joint's, as the relay resolved it (within its limits). CommandRejected says why not."""
        raise CommandRejected(ErrorCode.NO_ARM, f"{robot}/arm/gripper: the {self.name} backend moves no arm")

    async def stop_arm(self, robot: str) -> None:  # noqa: B027 - optional hook: a robot without an arm has none
        """The arm still at once (zero twist, a named pose and the gripper stop where they are). Awaits nothing
        the robot answers: it is on every stop's path."""

    async def estop_robot(self, robot: str) -> None:
        """An emergency stop: as ``stop_robot``, and a robot with a watchdog latches it (its gate's ``estop``).
        Must not wait for any answer from the robot (a navigator's cancel is sent, not awaited)."""
        await self.stop_robot(robot)

    def release_estop(self, robot: str) -> None:  # noqa: B027 - optional hook: only robots with a gate have a latch
        """The emergency stop of ``robot`` was reset: its watchdog's latch is lifted (the gate's ``drive``)."""

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        """The next (or a fresh enough) frame of a camera, or None when this backend has none."""
        return None

    def set_stream(self, robot: str, camera: str, fps: float) -> None:  # noqa: B027 - optional hook
        """Produce frames of a camera at up to ``fps`` (0 stops); frames arrive as FrameEvents."""

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:  # noqa: B027 - optional hook
        """Whether a streamed camera's frames need their JPEG (False: only H.264 viewers, which take the frame's
        ``pixels``); a backend may then skip the JPEG encode. Snapshots always get one."""

    def place_refusal(self, robot: str, x: float, y: float) -> CommandRejected | None:
        """Why ``robot`` cannot be placed at (x, y), or None when :meth:`place` can: asked before anything moves."""
        return CommandRejected(
            ErrorCode.UNSUPPORTED, f"{robot}: the {self.name} backend cannot place robots (only the sim backend can)"
        )

    async def place(self, robot: str, x: float, y: float, yaw: float) -> None:
        """Put ``robot`` at (x, y, yaw) in the map frame, stopped (a study task's start state). Only a simulated
        robot can be placed: CommandRejected says why not (:meth:`place_refusal`)."""
        refusal = self.place_refusal(robot, x, y)
        if refusal is not None:
            raise refusal

    def command_refusal(self, robot: str) -> str | None:
        """Why ``robot`` cannot be commanded at all (e.g. it is a recording), or None when it can."""
        return None

    async def playback(self, action: str, value: float | None) -> None:
        """Pause, resume, seek or change the rate of a replay; only the bag backend replays."""
        raise CommandRejected(
            ErrorCode.UNSUPPORTED, f"playback/{action}: the {self.name} backend is live, not a recording"
        )

    def map_grid(self) -> OccupancyGrid | None:
        """The occupancy grid goals are checked against, when this backend knows one."""
        return None

    async def recover(self) -> None:  # noqa: B027 - optional hook: most backends have nothing to rebuild
        """Re-create what a failure took away; called by the relay while ``failure`` is set."""

    def fleet_peer(self) -> FleetPeer | None:
        """Other relays serving the same robots (shared estop and leases), when this backend reaches them."""
        return None

    def health(self) -> dict[str, object]:
        """Extra fields for ``/healthz`` (JSON-serialisable, cheap: called on the loop); none by default."""
        return {}
