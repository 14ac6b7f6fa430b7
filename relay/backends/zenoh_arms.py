"""The fleet's arms over Zenoh (issue #32): each arm's joint_states in, MoveIt Servo's twists out, as CDR.

What the ``ros`` backend does for an arm through rclpy, with the zenoh backend's keys and bytes: the arm's
sensor_msgs/JointState is read by rosbags (relay/backends/raw_readers.py ``read_joint_state``), and the operator's
twist goes to ``servo_node/delta_twist_cmds`` as a geometry_msgs/TwistStamped in the arm's base link, stamped when
sent (MoveIt Servo drops a twist older than its ``incoming_command_timeout``). Named poses and the gripper are not
sent over Zenoh yet, as over ROS.
"""

from __future__ import annotations

import contextlib
import time
from typing import Any

from ..config import Robot
from .base import Vec3
from .cdr_encode import TWIST_STAMPED, CommandEncoder
from .raw_readers import JOINT_STATE_TYPE, Decode, Put, Warn, read_joint_state
from .zenoh_topics import ZenohPublisher, ZenohTopics


class ZenohArms:
    """The servo publishers of the robots with an arm, declared with the session and forgotten with it."""

    def __init__(self, decode: Decode, put: Put, warn: Warn) -> None:
        self._decode = decode
        self._put = put
        self._warn = warn
        self._servo: dict[str, tuple[ZenohPublisher, str]] = {}  # robot -> its servo's publisher, its base link

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
        return [subscription, publisher]

    def forget(self) -> None:
        for publisher, _ in self._servo.values():
            with contextlib.suppress(Exception):
                publisher.undeclare()
        self._servo = {}

    def moves(self, robot: str) -> bool:
        return robot in self._servo

    def twist(self, encode: CommandEncoder, robot: str, linear: Vec3, angular: Vec3) -> None:
        publisher, frame = self._servo[robot]
        publisher.put(encode.arm_twist(linear, angular, stamp=time.time(), frame=frame))
