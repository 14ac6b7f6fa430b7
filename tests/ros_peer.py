"""A small rclpy node the ROS integration tests run in their own process (a robot on the other side of DDS).

    python tests/ros_peer.py CONFIG.json

The JSON says what to publish: ``odom``/``amcl``/``pose`` poses, planned paths (nav_msgs/Path), sensor values,
raw and compressed images (from a real image file), any message serialized to a file (``raw``: CDR, restamped as it
is sent), and which command topics (and an arm's joint states) to echo. Every received command is
printed to stdout as one JSON line with the receive time on the shared monotonic clock, so the test can time the
deadman.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
import time
from typing import Any

import cv2
import rclpy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist, TwistStamped
from nav_msgs.msg import Odometry, Path
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import CompressedImage, Image, JointState, Temperature
from std_msgs.msg import Float32


def emit(record: dict[str, Any]) -> None:
    print(json.dumps(record), flush=True)  # noqa: T201 - the test reads these lines


def main() -> int:
    spec = json.loads(open(sys.argv[1]).read())  # noqa: SIM115
    rclpy.init()
    node = rclpy.create_node("test_peer")
    reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    publishers: list[tuple[Any, Any]] = []

    for item in spec.get("poses", []):
        kind, topic, x, y, yaw = item["kind"], item["topic"], item["x"], item["y"], item["yaw"]
        cls = {"odom": Odometry, "amcl": PoseWithCovarianceStamped, "pose": PoseStamped}[kind]
        message = cls()
        message.header.frame_id = item.get("frame", "map")
        pose = message.pose.pose if kind != "pose" else message.pose
        pose.position.x, pose.position.y, pose.position.z = x, y, 0.0
        pose.orientation.z, pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        publishers.append((node.create_publisher(cls, topic, reliable), message))

    for item in spec.get("paths", []):
        path = Path()
        path.header.frame_id = "map"
        for x, y in item["points"]:
            stamped = PoseStamped()
            stamped.header.frame_id = "map"
            stamped.pose.position.x, stamped.pose.position.y = float(x), float(y)
            stamped.pose.orientation.w = 1.0
            path.poses.append(stamped)
        publishers.append((node.create_publisher(Path, item["topic"], reliable), path))

    for item in spec.get("sensors", []):
        if item["type"] == "Temperature":
            message = Temperature()
            message.temperature = item["value"]
            cls = Temperature
        else:
            message = Float32()
            message.data = item["value"]
            cls = Float32
        publishers.append((node.create_publisher(cls, item["topic"], reliable), message))

    if "image" in spec:
        original = cv2.imread(spec["image"]["file"])
        assert original is not None, spec["image"]["file"]
        bgr = cv2.resize(original, (spec["image"]["width"], spec["image"]["height"]))
        raw = Image()
        raw.height, raw.width = bgr.shape[:2]
        raw.encoding = "rgb8"
        raw.step = raw.width * 3
        raw.data = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB).tobytes()
        raw.header.frame_id = "camera"
        publishers.append((node.create_publisher(Image, spec["image"]["raw_topic"], reliable), raw))
        compressed = CompressedImage()
        compressed.format = "jpeg"
        compressed.data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 70])[1].tobytes()
        compressed.header.frame_id = "camera"
        publishers.append(
            (node.create_publisher(CompressedImage, spec["image"]["compressed_topic"], reliable), compressed)
        )
        emit({"compressed_bytes": len(compressed.data)})

    for item in spec.get("raw_images", []):
        # Raw images of any size and encoding: the photo's bytes as they are (an encoding the relay cannot read
        # is still a well-formed message: its bytes are the right count for two bytes a pixel or three).
        photo = cv2.imread(item["file"])
        assert photo is not None, item["file"]
        bgr = cv2.resize(photo, (item["width"], item["height"]))
        raw = Image()
        raw.height, raw.width = bgr.shape[:2]
        raw.encoding = item.get("encoding", "rgb8")
        channels = 2 if raw.encoding.startswith("yuv422") else 3
        raw.step = raw.width * channels
        raw.data = bgr.tobytes()[: raw.step * raw.height]
        raw.header.frame_id = "camera"
        publishers.append((node.create_publisher(Image, item["topic"], reliable), raw))

    for item in spec.get("joint_states", []):  # an arm's joints, as joint_state_broadcaster publishes them
        joints = JointState()
        joints.name = list(item["names"])
        joints.position = [float(v) for v in item["positions"]]
        publishers.append((node.create_publisher(JointState, item["topic"], reliable), joints))

    for item in spec.get("raw", []):  # any message, serialized (CDR) by the test: a PointCloud2, a depth Image
        package, _, name = item["type"].rpartition("/")
        cls = getattr(importlib.import_module(package.replace("/", ".")), name)
        with open(item["file"], "rb") as cdr:
            message = deserialize_message(cdr.read(), cls)
        publishers.append((node.create_publisher(cls, item["topic"], reliable), message))

    def publish_all() -> None:
        stamp = node.get_clock().now().to_msg()
        for publisher, message in publishers:
            if hasattr(message, "header"):
                message.header.stamp = stamp
            publisher.publish(message)

    node.create_timer(1.0 / spec.get("rate", 20.0), publish_all)

    for topic in spec.get("echo_twist", []):
        node.create_subscription(
            Twist,
            topic,
            lambda m, t=topic: emit({"topic": t, "t": time.monotonic(), "linear": m.linear.x, "angular": m.angular.z}),
            reliable,
        )
    for topic in spec.get("echo_twist_stamped", []):  # MoveIt Servo's delta_twist_cmds
        node.create_subscription(
            TwistStamped,
            topic,
            lambda m, t=topic: emit(
                {
                    "topic": t,
                    "t": time.monotonic(),
                    "frame": m.header.frame_id,
                    "stamp": m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                    "linear": [m.twist.linear.x, m.twist.linear.y, m.twist.linear.z],
                    "angular": [m.twist.angular.x, m.twist.angular.y, m.twist.angular.z],
                }
            ),
            reliable,
        )
    for topic in spec.get("echo_joint_states", []):  # an arm's joint_state_broadcaster, as the relay also reads it
        node.create_subscription(
            JointState,
            topic,
            lambda m, t=topic: emit(
                {"topic": t, "t": time.monotonic(), "names": list(m.name), "positions": list(m.position)}
            ),
            reliable,
        )
    for topic in spec.get("echo_goal", []):
        node.create_subscription(
            PoseStamped,
            topic,
            lambda m, t=topic: emit(
                {
                    "topic": t,
                    "t": time.monotonic(),
                    "frame": m.header.frame_id,
                    "x": m.pose.position.x,
                    "y": m.pose.position.y,
                    "q": [m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w],
                }
            ),
            reliable,
        )
    emit({"ready": True})
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
