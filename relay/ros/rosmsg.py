"""What the relay knows of ROS messages: type names, the values it reads, units, stamps, poses and images.

One table per kind of message, used by ``relay.config`` (which sensor types robots.yaml may name, and their
default units), the ``ros`` backend (which rclpy classes to import) and the ``bag`` backend (which recorded
types to expect). rclpy message objects and ``rosbags``-deserialised ones have the same attribute names, so
each extractor here serves both. Nothing here imports rclpy.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..fleet.events import FrameEvent, PoseEvent
from ..media.imaging import compressed_to_jpeg, encode_jpeg, raw_to_bgr
from .tf import Transform


def message_type(module: str, cls: str) -> str:
    """``("nav_msgs.msg", "Odometry")`` -> ``"nav_msgs/msg/Odometry"``, the name recordings and graphs use."""
    return f"{module.split('.')[0]}/msg/{cls}"


@dataclass(frozen=True, slots=True)
class SensorType:
    """A sensor message the relay reads: its Python module and class, its default unit and its value."""

    module: str
    cls: str
    unit: str  # used when robots.yaml gives none
    value: Callable[[Any], float]


#: Sensor message types by their ROS name. Ratios (humidity, battery) are reported in percent.
SENSOR_TYPES: dict[str, SensorType] = {
    message_type(t.module, t.cls): t
    for t in (
        SensorType("std_msgs.msg", "Float32", "", lambda m: float(m.data)),
        SensorType("std_msgs.msg", "Float64", "", lambda m: float(m.data)),
        SensorType("std_msgs.msg", "Int32", "", lambda m: float(m.data)),
        SensorType("sensor_msgs.msg", "Temperature", "°C", lambda m: float(m.temperature)),
        SensorType("sensor_msgs.msg", "RelativeHumidity", "%", lambda m: 100.0 * float(m.relative_humidity)),
        SensorType("sensor_msgs.msg", "FluidPressure", "Pa", lambda m: float(m.fluid_pressure)),
        SensorType("sensor_msgs.msg", "Illuminance", "lx", lambda m: float(m.illuminance)),
        SensorType("sensor_msgs.msg", "BatteryState", "%", lambda m: 100.0 * float(m.percentage)),
    )
}

#: Pose sources (robots.yaml ``pose.source``) and the message each reads: (python module, class).
POSE_MESSAGES: dict[str, tuple[str, str]] = {
    "odom": ("nav_msgs.msg", "Odometry"),
    "amcl_pose": ("geometry_msgs.msg", "PoseWithCovarianceStamped"),
    "pose": ("geometry_msgs.msg", "PoseStamped"),
    "tf": ("tf2_msgs.msg", "TFMessage"),
}
POSE_TYPES: dict[str, str] = {source: message_type(*spec) for source, spec in POSE_MESSAGES.items()}
SCAN_TYPE = "sensor_msgs/msg/LaserScan"
IMAGE_TYPE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
MAP_TYPE = "nav_msgs/msg/OccupancyGrid"


def image_type(compressed: bool) -> str:
    """The message type of a camera topic: sensor_msgs/CompressedImage or sensor_msgs/Image."""
    return COMPRESSED_IMAGE_TYPE if compressed else IMAGE_TYPE


def header_stamp(header: Any, fallback: float | None = None) -> float:
    """A header's stamp in seconds. Publishers that leave it zero get ``fallback``: the recording time for
    a bag, the receive time (now) for a live graph."""
    value = float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9
    if value > 0:
        return value
    return time.time() if fallback is None else fallback


def message_stamp(message: Any, fallback: float | None = None) -> float:
    """The stamp of a message with or without a header (std_msgs/Float32 has none)."""
    header = getattr(message, "header", None)
    if header is not None:
        return header_stamp(header, fallback)
    return time.time() if fallback is None else fallback


def pose_event(robot: str, message: Any, stamp: float) -> PoseEvent:
    """An Odometry, PoseWithCovarianceStamped or PoseStamped as the robot's pose (in its header's frame)."""
    # Odometry and PoseWithCovarianceStamped nest the pose once more than PoseStamped.
    pose = message.pose.pose if hasattr(message.pose, "pose") else message.pose
    p, q = pose.position, pose.orientation
    return PoseEvent(
        robot,
        stamp,
        message.header.frame_id or "map",
        float(p.x),
        float(p.y),
        float(p.z),
        float(q.x),
        float(q.y),
        float(q.z),
        float(q.w),
    )


def transform_of(stamped: Any) -> Transform:
    """A geometry_msgs/TransformStamped's transform."""
    tr, q = stamped.transform.translation, stamped.transform.rotation
    return Transform((float(tr.x), float(tr.y), float(tr.z)), (float(q.x), float(q.y), float(q.z), float(q.w)))


def image_to_frame(
    robot: str, camera: str, stamp: float, message: Any, compressed: bool, *, jpeg: bool = True
) -> FrameEvent:
    """A sensor_msgs Image or CompressedImage as a JPEG frame (worker thread: OpenCV encodes here); with ``jpeg``
    False a raw image is not JPEG-encoded (its ``pixels`` feed the H.264 encoder; a 720p JPEG costs ~5 ms).

    Raises :class:`~relay.media.imaging.ImageError` or ``ValueError`` for an image it cannot read.
    """
    if compressed:
        passed, width, height = compressed_to_jpeg(bytes(message.data), message.format)
        return FrameEvent(robot, camera, stamp, width, height, passed)
    data = message.data
    # rclpy gives an array.array, rosbags a numpy array or bytes: a byte view of either, without a copy.
    pixels = data if isinstance(data, bytes) else memoryview(data).cast("B")
    width, height = int(message.width), int(message.height)
    bgr = raw_to_bgr(pixels, width, height, message.encoding, int(message.step), bool(message.is_bigendian))
    return FrameEvent(robot, camera, stamp, width, height, encode_jpeg(bgr) if jpeg else b"", bgr)
