"""A robot on the other side of DDS for the ROS benchmarks: publishes, in its own process, for a bounded time.

    python -m bench.ros_pub odom --topic /r1/odom --rate 1000 [--duration 60]   # --rate 0: flat out
    python -m bench.ros_pub images --spec '[{"topic": ..., "width": 640, "height": 480,
                                             "compressed": false, "photo": ".../front.jpg"}]' --rate 30

Every header stamp is ``time.monotonic()`` at publication (the benchmark subtracts it from receive times
taken in other processes: one clock on Linux). Prints ``{"ready": true}`` once its publishers exist, then
``{"published": N, "t": T}`` four times a second; stops after ``--duration`` or at end of input.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from typing import Any

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy


def emit(record: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(record) + "\n")
    sys.stdout.flush()


def set_stamp(header: Any, t: float) -> None:
    sec = int(t)
    header.stamp.sec = sec
    header.stamp.nanosec = int((t - sec) * 1e9)


def watch_stdin(stop: threading.Event) -> None:
    """End at end of input: the parent benchmark went away or is done with us."""
    for _ in sys.stdin:
        pass
    stop.set()


def odometry_messages(topic: str) -> tuple[Any, Any]:
    from nav_msgs.msg import Odometry

    message = Odometry()
    message.header.frame_id = "odom"
    message.child_frame_id = "base_footprint"
    # A real driver fills the covariances: the message is then its usual ~700 bytes.
    message.pose.covariance = [0.01 * (k % 7) for k in range(36)]
    message.twist.covariance = [0.02 * (k % 5) for k in range(36)]
    return Odometry, message


def image_messages(spec: dict[str, Any]) -> tuple[Any, Any]:
    import cv2
    from sensor_msgs.msg import CompressedImage, Image

    original = cv2.imread(spec["photo"])
    if original is None:
        raise SystemExit(f"cannot read {spec['photo']}")
    bgr = cv2.resize(original, (spec["width"], spec["height"]), interpolation=cv2.INTER_AREA)
    if spec.get("compressed"):
        compressed = CompressedImage()
        compressed.header.frame_id = "camera"
        compressed.format = "jpeg"
        compressed.data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, spec.get("quality", 80)])[1].tobytes()
        return CompressedImage, compressed
    raw = Image()
    raw.header.frame_id = "camera"
    raw.height, raw.width = bgr.shape[:2]
    raw.encoding = "rgb8"
    raw.step = raw.width * 3
    raw.data = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB).tobytes()
    return Image, raw


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("kind", choices=("odom", "images"))
    parser.add_argument("--topic", default="/r1/odom")
    parser.add_argument("--spec", default="[]", help="images: JSON list of streams")
    parser.add_argument("--rate", type=float, default=30.0, help="messages (per stream) per second; 0: flat out")
    parser.add_argument("--duration", type=float, default=120.0, help="seconds before stopping by itself")
    args = parser.parse_args()

    rclpy.init()
    node = rclpy.create_node("bench_publisher")
    # Reliable, depth 10: rclcpp's default, what most drivers publish odometry and images with.
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    streams: list[tuple[Any, Any]] = []
    if args.kind == "odom":
        cls, message = odometry_messages(args.topic)
        streams.append((node.create_publisher(cls, args.topic, qos), message))
    else:
        for spec in json.loads(args.spec):
            cls, message = image_messages(spec)
            streams.append((node.create_publisher(cls, spec["topic"], qos), message))
    stop = threading.Event()
    threading.Thread(target=watch_stdin, args=(stop,), daemon=True).start()
    emit({"ready": True})

    published = 0
    period = 1.0 / args.rate if args.rate > 0 else 0.0
    start = time.monotonic()
    deadline = start + args.duration
    next_report = start
    due = start
    try:
        while not stop.is_set():
            now = time.monotonic()
            if now >= deadline:
                break
            if now >= next_report:
                emit({"published": published, "t": now})
                next_report = now + 0.25
            if period:
                # Sleep to the next due time (not a fixed period): the average rate stays exact.
                delay = due - now
                if delay > 0:
                    time.sleep(delay)
                due = max(due + period, time.monotonic() - period)
            for publisher, message in streams:
                t = time.monotonic()
                set_stamp(message.header, t)
                if args.kind == "odom":
                    pose = message.pose.pose
                    pose.position.x = math.cos(0.5 * t)
                    pose.position.y = math.sin(0.5 * t)
                    pose.orientation.z, pose.orientation.w = math.sin(0.25 * t), math.cos(0.25 * t)
                publisher.publish(message)
                published += 1
    finally:
        emit({"published": published, "t": time.monotonic(), "final": True})
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
