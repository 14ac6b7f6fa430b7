"""The fleet's arms as the relay sees them: each arm's chain (read at start), its latest joints from the backend,
what clients are told of them (``<robot>/joints``), and the operator's arm commands through the same rules as a
base's.

An arm command (``<robot>/arm/twist``, ``/pose``, ``/gripper``) passes the motion gate once, as ``cmd_vel`` does
(relay/control/motion_gate.py: the role, a fresh command, the record, no latched estop, the robot's lease, which
covers base and arm); a twist is then clamped to ``arm.limits`` and checked a short step ahead against the arm's
rules (relay/arm/rules.py: joint margins, workspace, self-collision) from the latest joint state, on a worker thread
(2-7 ms of numpy), beside the client's later frames (relay/session/commands.py); a refused one stops the arm and the
reply names why, and one whose check ends after a stop of the arm or the robot is dropped. Its deadman is the
base's rule (relay/control/safety.py ``Deadman``) with the same timeout, kept apart so that an operator driving the
base does not keep a silent arm moving. The other stops
need nothing here: every stop of a robot (an estop, a take-over, a lease's end, shutdown) goes through the backend's
``stop_robot``, which stops its arm (relay/backends/base.py).

The arms are read again here, not taken from the backend: the rules the relay applies to a hand's command must be
the same whichever backend runs (over ROS the robot's own servo checks them once more).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Mapping

import numpy as np

from ..arm.fleet_arms import FleetArm, FleetArms, load_fleet_arms
from ..arm.kinematics import Vector, forward, points, velocity_step
from ..arm.named import NamedStateError
from ..arm.rules import ArmBounds, ClampedTwist, clamp_twist, step_refusal
from ..arm.sim_arm import LOOKAHEAD
from ..arm.wire import ArmCommand, ArmGripper, ArmPose, ArmTwist, JointsMessage, Vec3, joints_message
from ..backends.base import Backend
from ..config import Arm, Robot
from ..errors import CommandRejected
from ..fleet.events import JointStateEvent
from ..session.clients import Client
from ..station.outbox import Outbox
from ..station.work import Busy, WorkPool
from ..wire.fields import ErrorCode, RequestId
from .motion_gate import MotionGate
from .safety import Deadman

logger = logging.getLogger(__name__)


class ArmControl:
    def __init__(
        self,
        robots: Mapping[str, Robot],
        backend: Backend,
        gate: MotionGate,
        outbox: Outbox,
        generation: Callable[[str], int],
        *,
        deadman_timeout: float,
    ) -> None:
        """``generation``: the robot's stop generation (relay.control.control: every stop and new goal bumps it)."""
        self.robots = robots
        self.backend = backend
        self.gate = gate
        self.outbox = outbox
        self.loaded = FleetArms()
        #: Each arm's latest joint positions, in its chain's order.
        self.positions: dict[str, Vector] = {}
        #: Who moves which arm by twists, and when they last did: the base's rule, the base's timeout.
        self.deadman = Deadman(deadman_timeout)
        self.generation = generation
        #: Per robot, bumped by every stop of its arm made here: a twist whose check finishes after a stop is
        #: dropped, never sent (the robot's stops, an estop's or a lease change's, bump ``generation``).
        self._epoch: dict[str, int] = {}
        #: The twists' look-ahead checks, off the loop: 2-7 ms of numpy each (measured on this 2-core machine, the
        #: 7 ms under a load average of 17), at a hand's 20-30 Hz for every arm. One thread, one twist waiting.
        self._checks = WorkPool("arm-checks", workers=1, queue=1)

    async def start(self) -> None:
        # Parsing a URDF takes tens of milliseconds: off the loop.
        self.loaded = await asyncio.to_thread(load_fleet_arms, self.robots.values())

    def on_joints(self, event: JointStateEvent) -> JointsMessage | None:
        """A joint state from the backend: kept for the rules, and the message every client gets (None when the
        robot has no arm the relay could read, or the state lacks a joint of its chain)."""
        arm = self.loaded.arms.get(event.robot)
        if arm is None:
            return None
        by_name = dict(zip(event.names, event.positions, strict=False))
        try:
            q = np.array([by_name[name] for name in arm.model.names], dtype=np.float64)
        except KeyError as missing:
            logger.debug("%s's joint state lacks %s; ignored", event.robot, missing)
            return None
        self.positions[event.robot] = q
        skeleton = np.vstack([np.zeros(3), points(arm.model, q)])  # from the base link's origin
        return joints_message(
            event.robot, stamp=event.stamp, names=event.names, positions=event.positions, points=skeleton,
            gripper=arm.gripper_range,
        )  # fmt: skip

    # -- commands ---------------------------------------------------------------------------------

    async def handle(self, client: Client, command: ArmCommand, now: float, age: float) -> None:
        """Carry out an arm command that waited ``age`` seconds; raises ProtocolError when it is refused."""
        identifier = command.identifier
        # A recording (a bag, a replay) refuses every command as such first, whether its arm's files are here or not.
        self.gate.require_movable(client, command.robot, identifier, command.id, moves=False)
        arm = self._arm(command.robot, identifier, command.id)
        if isinstance(command, ArmTwist):
            await self._twist(client, command, arm, now, age)
        else:
            self.gate.admit(client, command.robot, identifier, command.id, now, age)
            # Not a stream of twists: nothing for the deadman to watch (its motion is bounded, and every stop ends it).
            self.deadman.release_robot(command.robot)
            try:
                if isinstance(command, ArmPose):
                    goal = arm.states.goal(command.name, self.positions.get(command.robot))
                    await self.backend.send_arm_pose(command.robot, command.name, goal)
                elif isinstance(command, ArmGripper):
                    wanted = command.state or command.position or 0.0
                    await self.backend.send_gripper(command.robot, wanted, arm.states.gripper_position(wanted))
            except NamedStateError as err:
                raise CommandRejected(ErrorCode.ARM_REFUSED, f"{identifier}: {err}", command.id) from err
        if command.id is not None:
            self.outbox.ack(client, command.id)

    async def _twist(self, client: Client, command: ArmTwist, arm: FleetArm, now: float, age: float) -> None:
        robot, identifier = command.robot, command.identifier
        if not command.moves:
            # A stop passes whenever the client may command the robot at all, an estop latched or not.
            self.gate.require_commandable(client, robot, identifier, command.id, now)
            self.deadman.release_robot(robot)
            await self._stop(robot)
            return
        self.gate.admit(client, robot, identifier, command.id, now, age)
        q = self.positions.get(robot)
        if q is None:
            raise CommandRejected(
                ErrorCode.ARM_REFUSED,
                f"{identifier}: refused: no joint state from {robot}'s arm yet, nothing to check the motion against",
                command.id,
            )
        config = self.robots[robot].arm
        assert config is not None  # the arm was read from it
        epoch, generation = self._epoch.get(robot, 0), self.generation(robot)
        try:
            twist, refusal = await self._checks.run(lambda: _checked(arm, config, q, command))
        except Busy:
            raise CommandRejected(
                ErrorCode.BUSY, f"{identifier}: dropped: the arm's last twists are still being checked", command.id
            ) from None
        # What may have changed during the check (an estop latched, the lease taken) refuses it now, and a stop
        # of the arm or the robot that came meanwhile voids it.
        self.gate.admit(client, robot, identifier, command.id, now, age)
        if self._epoch.get(robot, 0) != epoch or self.generation(robot) != generation:
            raise CommandRejected(
                ErrorCode.SUPERSEDED,
                f"{identifier}: dropped: {robot} was stopped while this twist was checked; nothing reached the arm",
                command.id,
            )
        if refusal is not None:
            self.deadman.release_robot(robot)
            await self._stop(robot)
            raise CommandRejected(
                ErrorCode.ARM_REFUSED, f"{identifier}: refused: {refusal}; the arm stopped where it is", command.id
            )
        if self.deadman.feed(robot, client.client_id, now) is not None:
            await self._stop(robot)  # the arm changed hands: it stops before the new hand's twist
        await self.backend.send_arm_twist(robot, twist.linear, twist.angular)

    async def _stop(self, robot: str) -> None:
        """The arm stops, and a twist still being checked for it is void."""
        self._epoch[robot] = self._epoch.get(robot, 0) + 1
        await self.backend.stop_arm(robot)

    def _arm(self, robot: str, identifier: str, request_id: RequestId | None) -> FleetArm:
        arm = self.loaded.arms.get(robot)
        if arm is None:
            why = self.loaded.absent.get(robot, "has no arm in robots.yaml")
            raise CommandRejected(ErrorCode.NO_ARM, f"{identifier}: {robot} {why}", request_id)
        return arm

    # -- stops ------------------------------------------------------------------------------------

    async def expire(self, now: float) -> None:
        """The deadman: an arm whose hand fell silent for the timeout stops."""
        for robot in self.deadman.expired(now):
            logger.info("stopping %s's arm: the hand's twists stopped (deadman)", robot)
            try:
                await self._stop(robot)
            except Exception:
                # The ticker must outlive one failed stop, or no deadman would ever fire again.
                logger.exception("deadman could not stop %s's arm", robot)

    async def client_gone(self, client_id: str) -> None:
        """The arms the client was moving stop at once."""
        for robot in self.deadman.release_client(client_id):
            logger.info("stopping %s's arm: operator %s disconnected", robot, client_id)
            await self._stop(robot)

    def close(self) -> None:
        self._checks.shutdown()


def _checked(arm: FleetArm, config: Arm, q: Vector, command: ArmTwist) -> tuple[ClampedTwist, str | None]:
    """The twist clamped to the arm's limits, and why a short step ahead along it breaks the arm's rules (joint
    margins, workspace, self-collision), or None. Pure numpy: run on the checks' thread."""
    linear, angular = command.linear, command.angular
    if command.frame == "tip":  # the tip's own axes, turned into the base link's
        rotation = forward(arm.model, q)[:3, :3]
        linear, angular = _vec3(rotation @ np.asarray(linear)), _vec3(rotation @ np.asarray(angular))
    twist = clamp_twist(linear, angular, config.limits)
    ahead = velocity_step(arm.model, q, twist.linear, twist.angular, LOOKAHEAD).positions
    return twist, step_refusal(arm.model, q, ahead, ArmBounds.of(config))


def _vec3(values: Vector) -> Vec3:
    return float(values[0]), float(values[1]), float(values[2])
