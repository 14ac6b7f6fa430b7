"""The fleet's arms on the ``ros`` backend's node (issue #32): each arm's joint_states in, MoveIt Servo's twists out.

What relay/backends/zenoh_arms.py does over Zenoh, through rclpy: the arm's sensor_msgs/JointState is read as a
message, and the operator's twist goes to ``servo_node/delta_twist_cmds`` as a geometry_msgs/TwistStamped in the arm's
base link, stamped when sent (MoveIt Servo drops a twist older than its ``incoming_command_timeout``). Named poses and
gripper goals go to ros2_control's controllers as trajectory_msgs/JointTrajectory and control_msgs' GripperCommand,
whose Python types the PyPI ROS wheels lack: over DDS they are refused, saying so (the zenoh backend sends both).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Final

from ..config import Robot
from ..errors import CommandRejected
from ..fleet.events import JointStateEvent
from ..ros.rosmsg import message_stamp
from ..wire.fields import ErrorCode
from .base import Vec3

#: Named poses and the gripper go to ros2_control's controllers, whose message packages the PyPI ROS wheels lack.
NOT_OVER_DDS: Final = (
    "the ros backend sends no named pose or gripper goal yet (it needs {}, which the PyPI ROS wheels lack); move "
    "the arm by hand, or run the zenoh backend, which sends both"
)


def stamp_header(header: Any, when: float) -> None:
    header.stamp.sec, header.stamp.nanosec = int(when), int((when - int(when)) * 1e9)


class RosArms:
    """The servo publishers of the robots with an arm on one node (made again with each rebuilt node)."""

    def __init__(self, messages: Callable[[str, str], Any], post: Callable[[JointStateEvent], None]) -> None:
        self._msg = messages
        self._post = post
        self._servo: dict[str, tuple[Any, str]] = {}  # robot -> its servo's publisher, its base link

    def create(self, node: Any, robot: Robot, commands_qos: Any, sensors_qos: Any) -> None:
        """Executor's node: the robot's joint_states subscription and servo publisher (none without an arm)."""
        arm, name = robot.arm, robot.name
        if arm is None:
            return
        twist = self._msg("geometry_msgs.msg", "TwistStamped")
        self._servo[name] = (node.create_publisher(twist, arm.topics.delta_twist_cmds, commands_qos), arm.base_link)

        def on_joints(m: Any) -> None:  # the executor's thread
            self._post(JointStateEvent(name, message_stamp(m), tuple(m.name), tuple(m.position), tuple(m.velocity)))

        node.create_subscription(self._msg("sensor_msgs.msg", "JointState"), arm.topics.joint_states, on_joints,
                                 sensors_qos)  # fmt: skip

    def moves(self, robot: str) -> bool:
        return robot in self._servo

    def twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        publisher, frame = self._servo[robot]
        message = self._msg("geometry_msgs.msg", "TwistStamped")()
        stamp_header(message.header, time.time())  # MoveIt Servo drops a twist older than incoming_command_timeout
        message.header.frame_id = frame  # its robot_link_command_frame
        message.twist.linear.x, message.twist.linear.y, message.twist.linear.z = (float(v) for v in linear)
        message.twist.angular.x, message.twist.angular.y, message.twist.angular.z = (float(v) for v in angular)
        publisher.publish(message)

    def stop(self, robot: str) -> None:
        """A zero twist to the robot's servo (nothing when it has no arm)."""
        if self.moves(robot):
            self.twist(robot, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    @staticmethod
    def refuse(robot: str, what: str, package: str) -> CommandRejected:
        return CommandRejected(ErrorCode.ARM_REFUSED, f"{robot}/arm/{what}: {NOT_OVER_DDS.format(package)}")
