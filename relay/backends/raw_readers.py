"""Serialized (CDR) messages to the relay's events, shared by the backends that receive bytes (``ros`` with
``raw=True``, ``zenoh``): TF chains, laser scans, and the low-rate types decoded whole by rosbags.

Each reader runs on the receiving thread (the ROS executor's, a Zenoh callback's), decodes, and hands an immutable
event to ``put`` (the backend's one thread crossing). Bytes that are not the message get one warning naming the
robot and the type; nothing is raised to the middleware's thread.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from ..fleet.events import Event, JointStateEvent, PathEvent, PoseEvent, RobotModelEvent, SensorEvent
from ..fleet.scan import RateCap, scan_event
from ..ros.rosmsg import POSE_TYPES, SCAN_TYPE, SENSOR_TYPES, header_stamp, message_stamp, transform_of
from ..ros.tf import TfPose

logger = logging.getLogger(__name__)

#: ``decode(data, type_name)``: the message (rosbags, rclpy's attribute names); ValueError naming the type.
Decode = Callable[[bytes, str], Any]
Put = Callable[[Event], None]
#: Where a reader's warning about bytes that are not the message goes (``logger.warning``'s signature): the zenoh
#: backend passes its rate-limited log (relay/logs/budget.py), anyone on the network can send such bytes.
Warn = Callable[..., None]

PATH_TYPE = "nav_msgs/msg/Path"
STRING_TYPE = "std_msgs/msg/String"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"


def read_tf(robot: str, tracker: TfPose, data: bytes, decode: Decode, put: Put, *, warn: Warn = logger.warning) -> None:
    """A tf2_msgs/TFMessage: the robot's pose once the chain map -> odom -> base is known (relay.ros.tf)."""
    message = _decoded(robot, data, decode, POSE_TYPES["tf"], "tf", warn)
    if message is None:
        return
    latest = None
    for t in message.transforms:
        if tracker.feed(t.header.frame_id, t.child_frame_id, transform_of(t)):
            latest = header_stamp(t.header)
    if latest is None:
        return
    result = tracker.pose()
    if result is not None:
        frame, pose = result
        (x, y, z), (qx, qy, qz, qw) = pose.translation, pose.rotation
        put(PoseEvent(robot, latest, frame, x, y, z, qx, qy, qz, qw))


def read_scan(robot: str, cap: RateCap, data: bytes, decode: Decode, put: Put, *, warn: Warn = logger.warning) -> None:
    """A sensor_msgs/LaserScan, at most the wire's scan rate (over it: not even decoded)."""
    if not cap.allow(robot, time.monotonic()):
        return
    message = _decoded(robot, data, decode, SCAN_TYPE, "scan", warn)
    if message is not None:
        put(scan_event(robot, header_stamp(message.header), message))


def read_sensor(
    robot: str, sensor: str, type_name: str, data: bytes, decode: Decode, put: Put, *, warn: Warn = logger.warning
) -> None:
    """A sensor reading of one of relay.ros.rosmsg.SENSOR_TYPES."""
    try:
        message = decode(data, type_name)
        value = SENSOR_TYPES[type_name].value(message)
    except ValueError as exc:
        warn("%s sensor %s: %s", robot, sensor, exc)
        return
    put(SensorEvent(robot, sensor, value, message_stamp(message)))


def path_points(message: Any) -> tuple[tuple[float, float], ...]:
    """A nav_msgs/Path's positions, map frame (the planner's frame: Nav2's global plan is in ``map``)."""
    return tuple((float(p.pose.position.x), float(p.pose.position.y)) for p in message.poses)


def _decoded(robot: str, data: bytes, decode: Decode, type_name: str, what: str, warn: Warn) -> Any | None:
    """The message, or None after one warning naming the robot and what it was (a bad sample changes nothing)."""
    try:
        return decode(data, type_name)
    except ValueError as exc:
        warn("%s %s: %s", robot, what, exc)
        return None


def read_path(robot: str, data: bytes, decode: Decode, put: Put, *, warn: Warn = logger.warning) -> None:
    message = _decoded(robot, data, decode, PATH_TYPE, "plan", warn)
    if message is not None:
        put(PathEvent(robot, path_points(message)))


def read_model(robot: str, data: bytes, decode: Decode, put: Put, *, warn: Warn = logger.warning) -> None:
    """robot_state_publisher's robot_description (std_msgs/String, URDF)."""
    message = _decoded(robot, data, decode, STRING_TYPE, "robot description", warn)
    if message is not None:
        put(RobotModelEvent(robot, str(message.data)))


def read_joint_state(robot: str, data: bytes, decode: Decode, put: Put, *, warn: Warn = logger.warning) -> None:
    """An arm's sensor_msgs/JointState (joint_state_broadcaster's): names, positions and velocities, whose lengths
    must agree (velocities may be empty); the relay checks the names against the arm's URDF where it reads them."""
    message = _decoded(robot, data, decode, JOINT_STATE_TYPE, "joint_states", warn)
    if message is None:
        return
    names, positions, velocities = list(message.name), list(message.position), list(message.velocity)
    if len(positions) != len(names) or len(velocities) not in (0, len(names)):
        warn("%s joint_states: %d names, %d positions, %d velocities", robot, len(names), len(positions),
             len(velocities))  # fmt: skip
        return
    put(JointStateEvent(robot, message_stamp(message), tuple(names), tuple(map(float, positions)),
                        tuple(map(float, velocities))))  # fmt: skip
