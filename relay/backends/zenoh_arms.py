"""The fleet's arms over Zenoh (issue #32): each arm's joint_states in, MoveIt Servo's twists out, as CDR.

What the ``ros`` backend does for an arm through rclpy, with the zenoh backend's keys and bytes: the arm's
sensor_msgs/JointState is read by rosbags (relay/backends/raw_readers.py ``read_joint_state``), and the operator's
twist goes to ``servo_node/delta_twist_cmds`` as a geometry_msgs/TwistStamped in the arm's base link, stamped when
sent (MoveIt Servo drops a twist older than its ``incoming_command_timeout``). A named pose goes to the arm
controller's ``joint_trajectory`` as a trajectory_msgs/JointTrajectory, and a gripper position to the gripper
controller's GripperCommand action as a goal (its ``_action/send_goal`` query; relay/ros/control_types.py): sent, not
awaited, and a goal the controller rejects or never answers is said in the log (a stop never waits for the robot).
"""

from __future__ import annotations

import contextlib
import time
from typing import Any, Final

from ..arm.named import JointGoal
from ..config import Robot
from ..errors import BackendUnavailable
from ..ros.control_types import JOINT_TRAJECTORY, read_accepted
from .base import Vec3
from .cdr_encode import TWIST_STAMPED, CommandEncoder
from .raw_readers import JOINT_STATE_TYPE, Decode, Put, Warn, read_joint_state
from .zenoh_topics import ZenohPublisher, ZenohTopics

#: How long a gripper controller has to answer a goal (s) before the query ends: its answer is only logged.
GRIPPER_ANSWER_S: Final = 2.0


class ZenohArms:
    """The servo publishers of the robots with an arm, declared with the session and forgotten with it."""

    def __init__(self, decode: Decode, put: Put, warn: Warn) -> None:
        self._decode = decode
        self._put = put
        self._warn = warn
        self._servo: dict[str, tuple[ZenohPublisher, str]] = {}  # robot -> its servo's publisher, its base link
        self._trajectory: dict[str, ZenohPublisher] = {}  # robot -> its arm controller's joint_trajectory
        self._gripper: dict[str, str] = {}  # robot -> its gripper controller's action
        self._topics: ZenohTopics | None = None
        self._encode: CommandEncoder | None = None

    def declare(self, topics: ZenohTopics, robot: Robot) -> list[Any]:
        """Worker thread: the robot's arm subscription and publisher (none without an arm); the entities to undeclare
        with the session."""
        arm = robot.arm
        if arm is None:
            return []
        name = robot.name
        on_joints = lambda data: read_joint_state(name, data, self._decode, self._put, warn=self._warn)  # noqa: E731
        subscription = topics.subscribe(f"{name} joint_states", arm.topics.joint_states, JOINT_STATE_TYPE, on_joints)
        publisher = topics.publisher(arm.topics.delta_twist_cmds, TWIST_STAMPED)
        self._servo[name] = (publisher, arm.base_link)
        self._trajectory[name] = topics.publisher(arm.topics.joint_trajectory, JOINT_TRAJECTORY)
        self._gripper[name] = arm.topics.gripper_cmd
        self._topics, self._encode = topics, topics.encoder
        return [subscription, publisher, self._trajectory[name]]

    def forget(self) -> None:
        for publisher in [*(servo for servo, _ in self._servo.values()), *self._trajectory.values()]:
            with contextlib.suppress(Exception):
                publisher.undeclare()
        self._servo, self._trajectory, self._gripper, self._topics = {}, {}, {}, None

    def moves(self, robot: str) -> bool:
        return robot in self._servo

    def stop(self, robot: str) -> None:
        """A zero twist to the robot's servo: MoveIt Servo stops the arm (nothing when it has no arm)."""
        if self.moves(robot):
            self.twist(robot, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def _session(self, robot: str, what: str) -> tuple[ZenohTopics, CommandEncoder]:
        if robot not in self._servo or self._topics is None or self._encode is None:
            raise BackendUnavailable(f"zenoh: no session to {robot}'s arm yet: its {what} cannot be sent")
        return self._topics, self._encode

    def twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        _, encode = self._session(robot, "twist")
        publisher, frame = self._servo[robot]
        publisher.put(encode.arm_twist(linear, angular, stamp=time.time(), frame=frame))

    def pose(self, robot: str, goal: JointGoal) -> None:
        """The named pose's joints to the arm controller, as a one-point trajectory."""
        _, encode = self._session(robot, "named pose")
        self._trajectory[robot].put(encode.joint_goal(goal))

    def gripper(self, robot: str, position: float) -> None:
        """A GripperCommand goal, sent; its answer is only logged (a rejection, or an error)."""
        topics, encode = self._session(robot, "gripper command")
        action = self._gripper[robot]
        decode = self._decode

        def answered(data: bytes | None, error: str | None) -> None:  # Zenoh's thread
            if data is None:
                self._warn("%s's gripper: %s/_action/send_goal answered with an error: %s", robot, action, error)
            elif not read_accepted(data, decode):
                self._warn("%s's gripper: %s rejected the goal (position %.4f)", robot, action, position)

        topics.query(f"{action}/_action/send_goal", encode.gripper(position), answered, GRIPPER_ANSWER_S)
