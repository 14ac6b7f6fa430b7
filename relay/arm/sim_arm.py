"""The simulator's arm: joint positions integrated from MoveIt Servo twists, named poses and a gripper, under the
arm's rules (relay.arm.rules), read back as a robot's joint_state_broadcaster publishes them.

No I/O and no clock of its own: the simulator calls :meth:`SimArm.step` at its physics rate with its time, and
commands carry the time they arrive at.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from ..config import Limits
from .kinematics import Vector, velocity_step
from .model import ArmModel
from .named import NAMED_SPEED_SCALE, NamedStateError, NamedStates
from .rules import ESTOP_REFUSAL, ArmBounds, ArmGate, ClampedTwist, clamp_twist, step_refusal

#: How far ahead (seconds) a twist is checked against the rules when it arrives, so that the reply can refuse it.
LOOKAHEAD: Final = 0.05


@dataclass(frozen=True, slots=True)
class JointState:
    """What sensor_msgs/JointState carries: the arm's joints, then the gripper's and its mimics'."""

    name: tuple[str, ...]
    position: tuple[float, ...]
    velocity: tuple[float, ...]


class SimArm:
    """One simulated arm. ``poses``: the SRDF's group states (group -> name -> joint -> position,
    relay.arm.srdf); those of the arm's joints are its named poses, those of the gripper joint the gripper's."""

    def __init__(
        self,
        model: ArmModel,
        limits: Limits,
        bounds: ArmBounds,
        poses: Mapping[str, Mapping[str, Mapping[str, float]]],
        timeout: float,
        positions: Sequence[float] | None = None,
    ) -> None:
        self.model = model
        self.limits = limits
        self.bounds = bounds
        self.gate = ArmGate(timeout)
        start = np.zeros(len(model.joints)) if positions is None else np.asarray(positions, dtype=np.float64)
        self._q: Vector = np.clip(start, model.lower, model.upper)
        self._qdot: Vector = np.zeros(len(model.joints))
        self._twist: ClampedTwist | None = None
        self._target: Vector | None = None  # a named pose under way
        self.states = NamedStates(model, poses)
        gripper = model.gripper
        self._grip = 0.0 if gripper is None else min(max(0.0, gripper.lower), gripper.upper)
        self._grip_target = self._grip
        self._grip_speed = 0.0
        self._last_step: float | None = None

    @property
    def positions(self) -> Vector:
        return self._q.copy()

    @property
    def named_poses(self) -> tuple[str, ...]:
        return tuple(sorted(self.states.arm))

    def servo(self, linear: Sequence[float], angular: Sequence[float], now: float) -> str | None:
        """A hand's twist (base frame; m/s, rad/s) arriving at ``now``: why it is refused, or None. It is followed
        until the next one, a stop, or the deadman's timeout."""
        twist = clamp_twist(linear, angular, self.limits)
        moving = any(twist.linear) or any(twist.angular)
        refused = self.gate.feed(now, moving)
        if refused is not None:
            return refused
        self._target = None
        if not moving:
            self.stop()
            return None
        ahead = velocity_step(self.model, self._q, twist.linear, twist.angular, LOOKAHEAD)
        refused = step_refusal(self.model, self._q, ahead.positions, self.bounds)
        if refused is not None:
            self.stop()
            return refused
        self._twist = twist
        return None

    def named(self, pose: str) -> str | None:
        """Move to a named pose (the SRDF's ``home``, ...) at a bounded joint speed: why not, or None."""
        if self.gate.latched:
            return ESTOP_REFUSAL
        try:
            return self.move_to(self.states.pose(pose), pose)
        except NamedStateError as err:
            return str(err)

    def move_to(self, target: Vector, what: str) -> str | None:
        """Move to these joint positions (the model's order), every joint arriving together at a named pose's
        speed, as an arm controller follows a trajectory's point: why not (``what`` names it), or None."""
        if self.gate.latched:
            return ESTOP_REFUSAL
        refused = step_refusal(self.model, self._q, target, self.bounds)
        if refused is not None:
            return f"{what}: {refused}"
        self._twist = None
        self._target = np.asarray(target, dtype=np.float64)
        return None

    def gripper(self, command: str | float) -> str | None:
        """Open, close (the SRDF's gripper states) or a position (m or rad, clipped to the joint's limits)."""
        if self.model.gripper is not None and self.gate.latched:
            return ESTOP_REFUSAL
        try:
            self._grip_target = self.states.gripper_position(command)
        except NamedStateError as err:
            return str(err)
        return None

    def stop(self) -> None:
        """Zero velocity at once: the twist, a named pose and the gripper stop where they are."""
        self.gate.stopped()
        self._twist = None
        self._target = None
        self._qdot = np.zeros(len(self.model.joints))
        self._grip_target = self._grip
        self._grip_speed = 0.0

    def estop(self) -> None:
        self.gate.latch()
        self.stop()

    def reset_estop(self) -> None:
        self.gate.reset()

    def step(self, now: float) -> str | None:
        """Advance to ``now`` (the simulator's clock): why the arm stopped in this step (the deadman, a rule), or
        None."""
        dt = 0.0 if self._last_step is None else max(0.0, now - self._last_step)
        self._last_step = now
        self._step_gripper(dt)
        expired = self.gate.tick(now)
        if expired is not None:
            self.stop()
            return expired
        if dt == 0.0:
            return None
        if self._twist is not None:
            proposed = velocity_step(self.model, self._q, self._twist.linear, self._twist.angular, dt).positions
        elif self._target is not None:
            proposed = self._toward(self._target, dt)
        else:
            self._qdot = np.zeros(len(self.model.joints))
            return None
        refused = step_refusal(self.model, self._q, proposed, self.bounds)
        if refused is not None:
            self.stop()
            return refused
        self._qdot = (proposed - self._q) / dt
        self._q = proposed
        if self._target is not None and np.array_equal(self._q, self._target):
            self._target = None
        return None

    def _toward(self, target: Vector, dt: float) -> Vector:
        """One step towards ``target``, every joint arriving together, the slowest at its scaled speed limit."""
        remaining = target - self._q
        needed = float(np.max(np.abs(remaining) / (self.model.velocity * NAMED_SPEED_SCALE)))
        if needed <= dt:
            return target.copy()
        return self._q + remaining * (dt / needed)

    def _step_gripper(self, dt: float) -> None:
        gripper = self.model.gripper
        if gripper is None:
            return
        gap = self._grip_target - self._grip
        reach = gripper.velocity * NAMED_SPEED_SCALE * dt
        moved = max(-reach, min(reach, gap))
        self._grip += moved
        self._grip_speed = moved / dt if dt > 0.0 else 0.0

    def joint_state(self) -> JointState:
        """The arm's joints, then the gripper joint and its mimics, as joint_states would carry them."""
        names, positions, velocities = list(self.model.names), [float(v) for v in self._q], list(map(float, self._qdot))
        gripper = self.model.gripper
        if gripper is not None:
            names.append(gripper.name)
            positions.append(self._grip)
            velocities.append(self._grip_speed)
            for name, multiplier, offset in gripper.mimics:
                names.append(name)
                positions.append(multiplier * self._grip + offset)
                velocities.append(multiplier * self._grip_speed)
        return JointState(tuple(names), tuple(positions), tuple(velocities))
