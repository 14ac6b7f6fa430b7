"""An arm's named poses and gripper states, from its SRDF's group states, as its controllers take them.

MoveIt's SRDF names whole-arm states (``home`` of group ``arm``: a position for every joint of the chain) and gripper
states (``open`` and ``close``: the gripper joint alone). The simulator moves its arm to them (relay/arm/sim_arm.py);
over ROS and Zenoh the relay sends a named pose as the arm controller's trajectory_msgs/JointTrajectory (one point,
reached in the time the slowest joint takes at NAMED_SPEED_SCALE of its limit) and a gripper state as the gripper
controller's control_msgs/GripperCommand goal (a position). Pure: no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Final

import numpy as np

from .kinematics import Vector
from .model import ArmModel

#: A named pose or the gripper moves at this share of each joint's velocity limit: MoveIt's
#: ``default_velocity_scaling_factor`` in turtlebot3_manipulation's joint_limits.yaml (0.48 rad/s of its 4.8).
NAMED_SPEED_SCALE: Final = 0.1
#: The shortest time a trajectory to a named pose is given (s): a controller given 0 s jumps at full speed.
MIN_TRAJECTORY_S: Final = 0.5


class NamedStateError(ValueError):
    """A named pose or gripper state the arm does not have, or a position it cannot take; says which."""


@dataclass(frozen=True, slots=True)
class JointGoal:
    """Where the arm's joints are sent: their names and positions (rad or m), reached ``seconds`` from now."""

    names: tuple[str, ...]
    positions: tuple[float, ...]
    seconds: float


class NamedStates:
    """The SRDF's states of one arm, sorted into whole-arm poses and gripper positions."""

    def __init__(self, model: ArmModel, poses: Mapping[str, Mapping[str, Mapping[str, float]]]) -> None:
        self.model = model
        self.arm: dict[str, Vector] = {}
        self.gripper: dict[str, float] = {}
        gripper = model.gripper
        for states in poses.values():
            for name, joints in states.items():
                if set(joints) == set(model.names):
                    self.arm[name] = np.array([joints[j] for j in model.names])
                elif gripper is not None and set(joints) == {gripper.name}:
                    self.gripper[name] = joints[gripper.name]

    def pose(self, name: str) -> Vector:
        """The joints of the named pose; NamedStateError lists the known ones when there is none."""
        if name not in self.arm:
            known = ", ".join(sorted(self.arm)) or "none"
            raise NamedStateError(f'no named pose "{name[:40]}" for the arm (the SRDF has: {known})')
        return self.arm[name]

    def goal(self, name: str, current: Vector | None) -> JointGoal:
        """The named pose as a trajectory's one point, timed from ``current`` (the arm's last joint state; None: from
        the farthest the joints' limits allow, as slow as a pose may take)."""
        target = self.pose(name)
        start = current if current is not None else np.where(target - self.model.lower > self.model.upper - target,
                                                             self.model.lower, self.model.upper)  # fmt: skip
        needed = float(np.max(np.abs(target - start) / (self.model.velocity * NAMED_SPEED_SCALE)))
        return JointGoal(self.model.names, tuple(float(v) for v in target), max(MIN_TRAJECTORY_S, needed))

    def gripper_position(self, command: str | float) -> float:
        """The gripper joint's position for ``open``, ``close`` (the SRDF's states) or a position, clipped to the
        joint's limits; NamedStateError says why not."""
        gripper = self.model.gripper
        if gripper is None:
            raise NamedStateError("this arm has no gripper_joint")
        if isinstance(command, str):
            if command not in self.gripper:
                known = ", ".join(sorted(self.gripper)) or "none"
                raise NamedStateError(f'no gripper state "{command[:40]}" (the SRDF has: {known})')
            command = self.gripper[command]
        if not math.isfinite(command):
            raise NamedStateError("a gripper position must be finite")
        return min(max(float(command), gripper.lower), gripper.upper)
