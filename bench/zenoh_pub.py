"""The robot of the zenoh ingest benchmark: a Zenoh router on 127.0.0.1 that publishes nav_msgs/Odometry on
rmw_zenoh's key, with its attachment, at a rate (0: flat out), as bench/ros_pub.py ``odom`` does over DDS.

    python -m bench.zenoh_pub --listen tcp/127.0.0.1:PORT --topic /r1/odom --rate 1000 --duration 300

The Odometry (covariances filled: ~700 bytes, as a real driver's) is serialized once by rosbags; each sample gets
``time.monotonic()`` as its header stamp (the benchmark subtracts it from receive times in other processes: one
clock on Linux) and the position ros_pub gives it. Prints ``{"ready": true}`` once the router listens, then
``{"published": N, "t": T}`` four times a second; stops after ``--duration`` or at end of input.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import struct
import sys
import threading
import time

import numpy as np
import zenoh

from relay.backends.zenoh_keys import Attachment, topic_key
from relay.ros.ros_env import typestore

from .ros_pub import emit, set_raw_stamp, watch_stdin

ODOMETRY = "nav_msgs/msg/Odometry"


def odometry_template() -> tuple[bytearray, int]:
    """The serialized Odometry and the offset of its pose (position x, y; orientation z, w are patched there)."""
    store = typestore()
    t = store.types
    vector = t["geometry_msgs/msg/Vector3"]
    pose = t["geometry_msgs/msg/Pose"](
        position=t["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
        orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    message = t[ODOMETRY](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="odom"),
        child_frame_id="base_footprint",
        pose=t["geometry_msgs/msg/PoseWithCovariance"](
            pose=pose, covariance=np.array([0.01 * (k % 7) for k in range(36)])
        ),
        twist=t["geometry_msgs/msg/TwistWithCovariance"](
            twist=t["geometry_msgs/msg/Twist"](linear=vector(x=0.0, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)),
            covariance=np.array([0.02 * (k % 5) for k in range(36)]),
        ),
    )
    data = bytearray(store.serialize_cdr(message, ODOMETRY))
    # 4-byte CDR header, stamp 8, "odom\0" (4 + 5), "base_footprint\0" aligned to 4 (4 + 15), pose aligned to 8.
    offset = 4 + 8 + 4 + 5
    offset += (-offset + 4) % 4 + 4 + 15
    offset = 4 + ((offset - 4 + 7) & ~7)
    assert struct.unpack_from("<d", data, offset + 48)[0] == 1.0, "the pose is not where it was expected"
    return data, offset


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--listen", required=True)
    parser.add_argument("--topic", default="/r1/odom")
    # rmw_zenoh's keys start with the ROS domain: the relay's zenoh backend takes it from ROS_DOMAIN_ID too.
    parser.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0") or 0))
    parser.add_argument("--rate", type=float, default=30.0, help="messages per second; 0: flat out")
    parser.add_argument("--duration", type=float, default=120.0, help="seconds before stopping by itself")
    args = parser.parse_args()
    config = zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("listen/endpoints", json.dumps([args.listen]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(config)
    key = topic_key("rmw_zenoh", args.domain, args.topic, ODOMETRY, typestore().hash_rihs01(ODOMETRY))
    publisher = session.declare_publisher(key)
    data, pose_at = odometry_template()
    gid = bytes(range(16))
    sequence = itertools.count(1)
    stop = threading.Event()
    threading.Thread(target=watch_stdin, args=(stop,), daemon=True).start()
    emit({"ready": True})
    published = 0
    period = 1.0 / args.rate if args.rate > 0 else 0.0
    start = time.monotonic()
    deadline, next_report, due = start + args.duration, start, start
    try:
        while not stop.is_set():
            now = time.monotonic()
            if now >= deadline:
                break
            if now >= next_report:
                emit({"published": published, "t": now})
                next_report = now + 0.25
            if period:
                delay = due - now
                if delay > 0:
                    time.sleep(delay)
                due = max(due + period, time.monotonic() - period)
            t = time.monotonic()
            set_raw_stamp(data, t)
            struct.pack_into("<2d", data, pose_at, math.cos(0.5 * t), math.sin(0.5 * t))
            struct.pack_into("<2d", data, pose_at + 40, math.sin(0.25 * t), math.cos(0.25 * t))
            publisher.put(bytes(data), attachment=Attachment(next(sequence), time.time_ns(), gid).encode())
            published += 1
    finally:
        emit({"published": published, "t": time.monotonic(), "final": True})
        session.close()  # type: ignore[no-untyped-call]
    return 0


if __name__ == "__main__":
    sys.exit(main())
