"""relay.ros.rosmsg: the one place that reads ROS messages, for both rclpy objects and rosbags-deserialised ones.

Messages here are plain namespaces with the ROS attribute names: that is all the extractors may rely on.
"""

from __future__ import annotations

import subprocess
import sys
from types import SimpleNamespace as NS

import cv2
import numpy as np
import pytest

from relay.fleet.events import PoseEvent
from relay.media.imaging import ImageError
from relay.ros import rosmsg


def _header(sec: int, nanosec: int, frame: str = "map") -> NS:
    return NS(stamp=NS(sec=sec, nanosec=nanosec), frame_id=frame)


def _pose(x: float, y: float, z: float, q: tuple[float, float, float, float]) -> NS:
    return NS(position=NS(x=x, y=y, z=z), orientation=NS(x=q[0], y=q[1], z=q[2], w=q[3]))


def test_type_names_and_tables() -> None:
    assert rosmsg.message_type("nav_msgs.msg", "Odometry") == "nav_msgs/msg/Odometry"
    assert rosmsg.POSE_TYPES["amcl_pose"] == "geometry_msgs/msg/PoseWithCovarianceStamped"
    assert rosmsg.image_type(compressed=True) == "sensor_msgs/msg/CompressedImage"
    assert rosmsg.image_type(compressed=False) == "sensor_msgs/msg/Image"
    assert rosmsg.SENSOR_TYPES["sensor_msgs/msg/Temperature"].unit == "°C"


def test_sensor_values_and_ratios_in_percent() -> None:
    types = rosmsg.SENSOR_TYPES
    assert types["std_msgs/msg/Float32"].value(NS(data=1.5)) == 1.5
    assert types["std_msgs/msg/Int32"].value(NS(data=7)) == 7.0
    assert types["sensor_msgs/msg/RelativeHumidity"].value(NS(relative_humidity=0.42)) == pytest.approx(42.0)
    battery = types["sensor_msgs/msg/BatteryState"]
    assert battery.unit == "%"
    assert battery.value(NS(percentage=0.8)) == pytest.approx(80.0)


def test_stamps_fall_back_when_zero_or_absent() -> None:
    assert rosmsg.header_stamp(_header(12, 500_000_000)) == pytest.approx(12.5)
    assert rosmsg.header_stamp(_header(0, 0), fallback=99.0) == 99.0
    assert rosmsg.message_stamp(NS(header=_header(3, 0))) == 3.0
    assert rosmsg.message_stamp(NS(data=1.0), fallback=5.0) == 5.0  # std_msgs have no header


def test_pose_from_each_message_kind() -> None:
    q = (0.0, 0.0, 0.6, 0.8)
    stamped = NS(header=_header(1, 0, "map"), pose=_pose(1.0, 2.0, 0.0, q))
    with_covariance = NS(header=_header(1, 0, "map"), pose=NS(pose=_pose(1.0, 2.0, 0.0, q), covariance=[0.0] * 36))
    odometry = NS(header=_header(1, 0, ""), pose=NS(pose=_pose(1.0, 2.0, 0.0, q)), twist=None)
    expected = PoseEvent("r1", 1.0, "map", 1.0, 2.0, 0.0, 0.0, 0.0, 0.6, 0.8)
    for message in (stamped, with_covariance, odometry):  # an empty frame_id reads as "map"
        assert rosmsg.pose_event("r1", message, 1.0) == expected


def test_transform_of_a_stamped_transform() -> None:
    stamped = NS(transform=NS(translation=NS(x=1.0, y=-2.0, z=0.5), rotation=NS(x=0.0, y=0.0, z=0.0, w=1.0)))
    transform = rosmsg.transform_of(stamped)
    assert transform.translation == (1.0, -2.0, 0.5)
    assert transform.rotation == (0.0, 0.0, 0.0, 1.0)


def test_raw_image_to_jpeg_frame_from_bytes_and_arrays() -> None:
    pixels = np.zeros((4, 6, 3), dtype=np.uint8)
    pixels[:, :, 0] = 255  # red in rgb8
    for data in (pixels.tobytes(), pixels.reshape(-1)):  # a bag gives numpy, rclpy an array: both byte views
        message = NS(data=data, width=6, height=4, encoding="rgb8", step=18, is_bigendian=False)
        frame = rosmsg.image_to_frame("r1", "front", 2.0, message, compressed=False)
        assert (frame.robot, frame.camera, frame.stamp, frame.width, frame.height) == ("r1", "front", 2.0, 6, 4)
        decoded = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_COLOR)
        assert decoded is not None
        assert decoded.shape == (4, 6, 3) and decoded[..., 2].mean() > 200  # still red, now BGR


def test_compressed_image_and_unreadable_image() -> None:
    ok, png = cv2.imencode(".png", np.full((8, 10, 3), 128, np.uint8))
    assert ok
    frame = rosmsg.image_to_frame("r1", "front", 0.0, NS(data=png.tobytes(), format="png"), compressed=True)
    assert (frame.width, frame.height) == (10, 8) and frame.jpeg.startswith(b"\xff\xd8")
    bad = NS(data=b"\0" * 4, width=6, height=4, encoding="rgb8", step=18, is_bigendian=False)
    with pytest.raises(ImageError):
        rosmsg.image_to_frame("r1", "front", 0.0, bad, compressed=False)


def test_importing_message_knowledge_does_not_import_rclpy() -> None:
    # The ros backend imports rclpy lazily: config and the bag backend must load on machines without ROS.
    code = "import sys, relay.ros.rosmsg, relay.config, relay.backends.bag; print('rclpy' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "False"
