"""What a robot's base receives on its cmd_vel, timed where the base is: one JSON line per command.

    python -m bench.base_probe --topic /robot2/cmd_vel              (over DDS: rclpy, this process's ROS domain)
    python -m bench.base_probe --topic /robot2/cmd_vel --zenoh tcp/127.0.0.1:7447   (rmw_zenoh's keys, CDR)
    python -m bench.base_probe --topic /robot3/servo_node/delta_twist_cmds --stamped   (MoveIt Servo's input, DDS)

Each line is ``{"t": <CLOCK_MONOTONIC s>, "linear": x, "angular": z}`` (with ``--stamped``, a TwistStamped's whole
``linear`` and ``angular`` vectors and its ``frame``); the first is ``{"ready": true}``. The monotonic clock is the
machine's, the same in every process: bench/bench_estop.py and bench/bench_arm.py compare these times with when
their frames left. A benchmark, not a tool.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from typing import Any


def emit(line: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(line) + "\n")
    sys.stdout.flush()


def over_dds(topic: str, stamped: bool) -> None:
    import rclpy
    from geometry_msgs.msg import Twist, TwistStamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    rclpy.init()
    node = rclpy.create_node("base_probe")

    def on_twist(message: Any) -> None:
        emit({"t": time.monotonic(), "linear": message.linear.x, "angular": message.angular.z})

    def on_stamped(message: Any) -> None:
        linear, angular = message.twist.linear, message.twist.angular
        emit(
            {
                "t": time.monotonic(),
                "frame": message.header.frame_id,
                "linear": [linear.x, linear.y, linear.z],
                "angular": [angular.x, angular.y, angular.z],
            }
        )

    qos = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(TwistStamped if stamped else Twist, topic, on_stamped if stamped else on_twist, qos)
    emit({"ready": True})
    rclpy.spin(node)


def over_zenoh(topic: str, endpoint: str) -> None:
    import zenoh

    from relay.backends.zenoh_keys import topic_selector
    from relay.ros.ros_env import typestore

    store = typestore()
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    session = zenoh.open(config)

    def on_sample(sample: Any) -> None:
        at = time.monotonic()
        message = store.deserialize_cdr(bytes(sample.payload.to_bytes()), "geometry_msgs/msg/Twist")
        emit({"t": at, "linear": message.linear.x, "angular": message.angular.z})

    session.declare_subscriber(topic_selector("rmw_zenoh", 0, topic), on_sample)
    emit({"ready": True})
    threading.Event().wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--topic", required=True)
    parser.add_argument("--zenoh", default=None, help="a Zenoh endpoint: listen there instead of over DDS")
    parser.add_argument("--stamped", action="store_true", help="geometry_msgs/TwistStamped (over DDS)")
    args = parser.parse_args()
    if args.zenoh:
        over_zenoh(args.topic, args.zenoh)
    else:
        over_dds(args.topic, args.stamped)


if __name__ == "__main__":
    main()
