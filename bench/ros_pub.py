"""A robot on the other side of DDS for the ROS benchmarks: publishes, in its own process, for a bounded time.

    python -m bench.ros_pub odom --topic /r1/odom --rate 1000 [--duration 60]   # --rate 0: flat out
    python -m bench.ros_pub fleet --robots 100 --rate 30 --scan-rate 10   # /rNNN/odom and /rNNN/scan each
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
import struct
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


class FleetMessages:
    """Every robot's Odometry and LaserScan (360 beams), serialized once and published as bytes with the stamp
    and the position written in place: rclpy's message conversion would cost this process more than the relay
    spends on the same messages, and the subject is the relay."""

    def __init__(self, robots: int) -> None:
        from rclpy.serialization import serialize_message
        from sensor_msgs.msg import LaserScan

        _, odom = odometry_messages("")
        odom.pose.pose.position.x = 12345.678
        self.odom = bytearray(serialize_message(odom))
        self.odom_x = bytes(self.odom).find(struct.pack("<d", 12345.678))
        assert self.odom_x > 0
        scan = LaserScan()
        scan.header.frame_id = "laser"
        scan.angle_min, scan.angle_max, scan.angle_increment = -math.pi, math.pi, 2 * math.pi / 360
        scan.range_min, scan.range_max = 0.1, 8.0
        scan.ranges = [2.0 + math.sin(k / 9.0) for k in range(360)]
        self.scan = bytearray(serialize_message(scan))
        self.robots = robots

    def odometry(self, index: int, t: float) -> bytes:
        set_raw_stamp(self.odom, t)
        struct.pack_into("<dd", self.odom, self.odom_x, index + math.cos(0.5 * t), math.sin(0.5 * t))
        return bytes(self.odom)

    def laser(self, t: float) -> bytes:
        set_raw_stamp(self.scan, t)
        return bytes(self.scan)


def set_raw_stamp(data: bytearray, t: float) -> None:
    sec = int(t)
    struct.pack_into("<iI", data, 4, sec, int((t - sec) * 1e9))  # after the 4-byte CDR header (little-endian)


def fleet_topics(robots: int) -> list[str]:
    return [f"/r{i:03d}" for i in range(robots)]


def run_fleet(node: Any, args: argparse.Namespace, qos: QoSProfile, stop: threading.Event) -> int:
    """Every robot at ``--rate`` Odometry and ``--scan-rate`` LaserScan, spread evenly over each period."""
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import LaserScan

    messages = FleetMessages(args.robots)
    names = fleet_topics(args.robots)
    odoms = [node.create_publisher(Odometry, f"{n}/odom", qos) for n in names]
    scans = [node.create_publisher(LaserScan, f"{n}/scan", qos) for n in names]
    emit({"ready": True})
    # One tick per odometry message of any robot; each robot's scan goes out every rate/scan_rate of its ticks.
    tick = 1.0 / (args.rate * args.robots)
    every = max(1, round(args.rate / args.scan_rate)) if args.scan_rate > 0 else 0
    published = 0
    start = time.monotonic()
    deadline, next_report, due, n = start + args.duration, start, start, 0
    while not stop.is_set():
        now = time.monotonic()
        if now >= deadline:
            break
        if now >= next_report:
            emit({"published": published, "t": now})
            next_report = now + 0.25
        if due > now:
            time.sleep(due - now)
        due = max(due + tick, time.monotonic() - 0.1)  # at most 0.1 s of catching up after a stall
        robot, cycle = n % args.robots, n // args.robots
        t = time.monotonic()
        odoms[robot].publish(messages.odometry(robot, t))
        published += 1
        if every and cycle % every == robot % every:
            scans[robot].publish(messages.laser(t))
            published += 1
        n += 1
    return published


#: Frames of a panning camera (``"pan": true`` in a stream's spec): 6 pixels a frame, back and forth.
PAN_FRAMES, PAN_STEP = 60, 6


class PanningImages:
    """A raw rgb8 camera panning across the photo: every frame serialized once and published as bytes with its stamp
    written in place (building a 2.7 MB rclpy Image per frame would cost the publisher more than the relay)."""

    def __init__(self, spec: dict[str, Any]) -> None:
        import cv2
        from rclpy.serialization import serialize_message
        from sensor_msgs.msg import Image

        original = cv2.imread(spec["photo"])
        if original is None:
            raise SystemExit(f"cannot read {spec['photo']}")
        width, height = spec["width"], spec["height"]
        wide = cv2.resize(original, (width + PAN_STEP * PAN_FRAMES, height), interpolation=cv2.INTER_AREA)
        self.frames: list[bytearray] = []
        for i in list(range(PAN_FRAMES)) + list(range(PAN_FRAMES - 1, 0, -1)):
            raw = Image()
            raw.header.frame_id = "camera"
            raw.height, raw.width, raw.encoding, raw.step = height, width, "rgb8", width * 3
            crop = wide[:, PAN_STEP * i : PAN_STEP * i + width]
            raw.data = cv2.cvtColor(crop, cv2.COLOR_BGR2RGB).tobytes()
            self.frames.append(bytearray(serialize_message(raw)))
        self.index = 0

    def next(self, t: float) -> bytes:
        data = self.frames[self.index % len(self.frames)]
        self.index += 1
        set_raw_stamp(data, t)
        return bytes(data)


def image_messages(spec: dict[str, Any]) -> tuple[Any, Any]:
    import cv2
    from sensor_msgs.msg import CompressedImage, Image

    if spec.get("pan"):
        return Image, PanningImages(spec)
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
    parser.add_argument("kind", choices=("odom", "images", "fleet"))
    parser.add_argument("--robots", type=int, default=100, help="fleet: robots /r000 ... each with odom and scan")
    parser.add_argument("--scan-rate", type=float, default=10.0, help="fleet: LaserScans per robot per second")
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
    if args.kind == "fleet":
        try:
            emit({"published": run_fleet(node, args, qos, stop), "t": time.monotonic(), "final": True})
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
        return 0
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
                if isinstance(message, PanningImages):
                    publisher.publish(message.next(t))
                    published += 1
                    continue
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
