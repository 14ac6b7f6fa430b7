"""The simulated fleet's arms: a :class:`relay.arm.sim_arm.SimArm` for each robot whose arm could be read, stepped
with the simulator's time, its joints read back as joint_state_broadcaster publishes them.

No I/O and no clock: the sim backend steps them at its physics rate and passes the time in. An arm starts at its
SRDF's ``home`` pose when there is one (else every joint at 0, within its limits).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Mapping

from ..arm.fleet_arms import FleetArms
from ..arm.kinematics import Vector, forward
from ..arm.rules import ArmBounds
from ..arm.sim_arm import SimArm
from ..config import Robot
from ..errors import CommandRejected
from ..fleet.events import JointStateEvent
from ..wire.fields import ErrorCode
from .valve import ValveWheel, tip_in_map

logger = logging.getLogger(__name__)

#: The pose an arm starts in, when its SRDF names it.
START_POSE = "home"
#: How often each arm's joints are published (Hz): enough for the twin (the client smooths between states), a
#: tenth of the 100 Hz of turtlebot3_manipulation's joint_state_broadcaster, which nobody watches at that rate here.
JOINT_STATE_RATE = 20.0
#: A robot whose arm may turn the valve stands this near it (m): an arm's reach and the robot's radius, with room.
VALVE_NEAR = 1.0


class SimArms:
    def __init__(self, robots: Mapping[str, Robot], loaded: FleetArms, timeout: float) -> None:
        """``timeout``: the arm's own deadman (the robot side's, as MoveIt Servo's ``incoming_command_timeout``):
        the relay's ``safety.deadman_timeout``."""
        self.loaded = loaded
        self.arms: dict[str, SimArm] = {}
        for name, fleet_arm in loaded.arms.items():
            arm = robots[name].arm
            assert arm is not None  # loaded from it
            bounds = ArmBounds.of(arm)
            home = next((states[START_POSE] for states in fleet_arm.poses.values() if START_POSE in states), None)
            model = fleet_arm.model
            start = [home[j] for j in model.names] if home is not None and set(model.names) <= set(home) else None
            self.arms[name] = SimArm(model, arm.limits, bounds, fleet_arm.poses, timeout, positions=start)

    def __iter__(self) -> Iterator[str]:
        return iter(self.arms)

    def arm(self, robot: str, identifier: str) -> SimArm:
        arm = self.arms.get(robot)
        if arm is None:
            why = self.loaded.absent.get(robot, "has no arm in robots.yaml")
            raise CommandRejected(ErrorCode.NO_ARM, f"{identifier}: {robot} {why}")
        return arm

    def step(self, now: float) -> None:
        for name, arm in self.arms.items():
            stopped = arm.step(now)
            if stopped is not None:
                logger.info("%s's arm stopped: %s", name, stopped)

    def stop(self, robot: str) -> None:
        arm = self.arms.get(robot)
        if arm is not None:
            arm.stop()

    def tip(self, robot: str) -> Vector:
        """The arm's tip in its base link frame (m)."""
        arm = self.arms[robot]
        return forward(arm.model, arm.positions)[:3, 3]

    def camera_pose(self, robot: str, pose: tuple[float, float, float]) -> tuple[float, float, float, float, float]:
        """Where a camera on the arm's tip looks from, for the simulator's camera (relay/sim/camera.py): its x, y and
        height in the map and its heading and downward pitch (rad), looking along the tip link's +x (the gripper's
        fingers point that way on OpenManipulator-X) from the robot at ``pose`` (x, y, yaw). No roll: the arm's
        joints are one yaw and pitches."""
        arm = self.arms[robot]
        tip = forward(arm.model, arm.positions)
        x, y, z = tip_in_map(pose, tip[:3, 3])
        ahead = tip[:3, 0]
        yaw = pose[2] + math.atan2(float(ahead[1]), float(ahead[0]))
        pitch = math.atan2(-float(ahead[2]), math.hypot(float(ahead[0]), float(ahead[1])))
        return x, y, z, yaw, pitch

    def gripping(self, robot: str) -> bool:
        """Whether the gripper is closed: nearer its closed end than its open one."""
        arm = self.arms[robot]
        gripper = arm.model.gripper
        if gripper is None:
            return False
        return arm.joint_state().position[len(arm.model.joints)] < (gripper.lower + gripper.upper) / 2

    def turn(self, valve: ValveWheel, poses: Mapping[str, tuple[float, float, float]], now: float) -> None:
        """The valve wheel follows the gripper of the nearest arm within VALVE_NEAR of it (``poses``: each arm's
        robot's x, y and yaw in the map; ``now``: the simulated time)."""
        v = valve.valve
        near = {n: math.hypot(x - v.x, y - v.y) for n, (x, y, _) in poses.items()}
        robot = min((n for n, d in near.items() if d <= VALVE_NEAR), key=near.__getitem__, default=None)
        tip = tip_in_map(poses[robot], self.tip(robot)) if robot is not None else None
        if valve.step(tip, robot is not None and self.gripping(robot), now):
            logger.info("sim: %s turned the valve shut: the %s leak stops", robot, v.hazard)

    def states(self, stamp: float) -> list[JointStateEvent]:
        events = []
        for name, arm in self.arms.items():
            state = arm.joint_state()
            events.append(JointStateEvent(name, stamp, state.name, state.position, state.velocity))
        return events
