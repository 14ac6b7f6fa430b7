"""The robots' side of the zenoh backend's tests: a Zenoh router on 127.0.0.1 (a free port of its own) that also
publishes and subscribes as a robot under rmw_zenoh would, written apart from the relay's code.

Keys and the attachment are spelled out here from rmw_zenoh's source (not taken from relay/backends/zenoh_keys.py);
messages are built with rosbags (the CDR reference the relay is checked against), an Odometry also by hand.
"""

from __future__ import annotations

import json
import socket
import struct
import threading
import time
from typing import Any

import zenoh
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.LATEST)
T = STORE.types


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def router_config(port: int) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("connect/endpoints", "[]")
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


def key(topic: str, dds_type: str, ros_type: str, domain: int = 0) -> str:
    """rmw_zenoh's ``<domain>/<topic>/<pkg>::msg::dds_::<Name>_/<RIHS01 hash>``."""
    return f"{domain}/{topic.strip('/')}/{dds_type}/{STORE.hash_rihs01(ros_type)}"


def stamp(t: float) -> Any:
    return T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=int((t - int(t)) * 1e9))


def header(t: float, frame: str) -> Any:
    return T["std_msgs/msg/Header"](stamp=stamp(t), frame_id=frame)


def odometry_by_hand(sec: int, nanosec: int, frame: str, child: str, pose: tuple[float, ...]) -> bytes:
    """A nav_msgs/Odometry in XCDR1 little-endian, laid out by hand (covariances and twist zero)."""

    def string(s: str, offset: int) -> tuple[bytes, int]:
        data = s.encode() + b"\0"
        pad = (-offset) % 4
        return b"\0" * pad + struct.pack("<I", len(data)) + data, offset + pad + 4 + len(data)

    body = struct.pack("<iI", sec, nanosec)
    part, offset = string(frame, len(body))
    body += part
    part, offset = string(child, offset)
    body += part
    body += b"\0" * ((-offset) % 8)
    body += struct.pack("<7d", *pose) + bytes(36 * 8)  # pose, covariance
    body += bytes(6 * 8) + bytes(36 * 8)  # twist, covariance
    return b"\x00\x01\x00\x00" + body


def odometry_by_rosbags(sec: int, nanosec: int, frame: str, child: str, pose: tuple[float, ...]) -> bytes:
    x, y, z, qx, qy, qz, qw = pose
    p = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=x, y=y, z=z),
        orientation=T["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
    )
    import numpy as np

    vector = T["geometry_msgs/msg/Vector3"]
    message = T["nav_msgs/msg/Odometry"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame
        ),
        child_frame_id=child,
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=vector(x=0.0, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)),
            covariance=np.zeros(36),
        ),
    )
    return bytes(STORE.serialize_cdr(message, "nav_msgs/msg/Odometry"))


def attachment(sequence: int) -> bytes:
    """rmw_zenoh's attachment: int64 sequence, int64 ns timestamp, LEB128 16 + a 16-byte GID."""
    return struct.pack("<qqB", sequence, time.time_ns(), 16) + b"G" * 16


class Received:
    """Samples a robot received on one key expression: (key, payload, attachment)."""

    def __init__(self) -> None:
        self.samples: list[tuple[str, bytes, bytes | None]] = []
        self._lock = threading.Lock()

    def __call__(self, sample: Any) -> None:
        extra = sample.attachment.to_bytes() if sample.attachment is not None else None
        with self._lock:
            self.samples.append((str(sample.key_expr), sample.payload.to_bytes(), extra))

    def all(self) -> list[tuple[str, bytes, bytes | None]]:
        with self._lock:
            return list(self.samples)
