"""Zenoh key expressions and the rmw_zenoh attachment, as bytes and strings: no zenoh import, no I/O.

**Topics.** rmw_zenoh (ros2/rmw_zenoh, ``rmw_zenoh_cpp/src/detail/liveliness_utils.cpp``, ``TopicInfo``) puts a
topic's samples on ``<domain_id>/<topic without its outer slashes>/<DDS type name>/<type hash>``, e.g.
``0/robot1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_3cc9...``. The relay subscribes to
``<domain>/<topic>/*/*`` (any type, any hash: a robot of another distribution or an older rmw_zenoh that sends
``TypeHashNotSupported`` still arrives) and reads the type from the key, so a sample of a type it cannot decode gets
a message naming it. It publishes on the exact key, with the RIHS01 hash rosbags computes, because an rmw_zenoh
subscriber declares the exact key too. zenoh-bridge-ros2dds (``keys: bridge``) maps a DDS topic to just
``<topic without its leading slash>`` (no domain, no type): then the relay trusts the configured type.

**The attachment** (``attachment_helpers.cpp``, ``AttachmentData::serialize_to_zbytes``): zenoh-ext serialization of
int64 sequence number, int64 source timestamp (ns since the epoch), and the 16-byte publisher GID as a sequence
(LEB128 length 16, then the bytes): 33 bytes, little-endian.

**Fleet keys** (this relay's own, not ROS's): ``<prefix>/estop`` carries an emergency stop from any relay to every
other; ``<prefix>/lease/<robot>/<relay-id>/<client>`` is a liveliness token per lease held, which Zenoh withdraws
when the relay holding it goes away.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import Literal

import orjson

KeyStyle = Literal["rmw_zenoh", "bridge"]
KEY_STYLES: tuple[KeyStyle, ...] = ("rmw_zenoh", "bridge")

#: rmw's GID storage: 16 bytes (RMW_GID_STORAGE_SIZE since Iron).
GID_SIZE = 16
_ATTACHMENT = struct.Struct("<qqB")
ATTACHMENT_SIZE = _ATTACHMENT.size + GID_SIZE
#: Characters a key chunk may not hold (Zenoh's wildcards and separators, and ``@``-verbatim chunks).
_UNSAFE = re.compile(r"[/*$#?@\s]")


def dds_type(ros_type: str) -> str:
    """``nav_msgs/msg/Odometry`` -> ``nav_msgs::msg::dds_::Odometry_`` (the name rmw_zenoh puts in keys)."""
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def ros_type(dds: str) -> str | None:
    """The inverse of :func:`dds_type`; None when ``dds`` is not of that shape."""
    parts = dds.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        return None
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def _strip(topic: str) -> str:
    return topic.strip("/")


def topic_key(style: KeyStyle, domain: int, topic: str, type_name: str, type_hash: str) -> str:
    """The key a publisher of ``topic`` (ROS type ``type_name``) puts its samples on."""
    if style == "bridge":
        return _strip(topic)
    return f"{domain}/{_strip(topic)}/{dds_type(type_name)}/{type_hash}"


def topic_selector(style: KeyStyle, domain: int, topic: str) -> str:
    """The key expression a subscriber of ``topic`` declares: every type and hash (rmw_zenoh), or the topic."""
    if style == "bridge":
        return _strip(topic)
    return f"{domain}/{_strip(topic)}/*/*"


def key_type(style: KeyStyle, key: str) -> str | None:
    """The ROS type a sample's key names (rmw_zenoh: its second-last chunk), None when the key names none."""
    if style == "bridge":
        return None
    chunks = key.split("/")
    if len(chunks) < 4:
        return None
    return ros_type(chunks[-2]) or chunks[-2]


@dataclass(frozen=True, slots=True)
class Attachment:
    sequence: int
    timestamp_ns: int
    gid: bytes

    def encode(self) -> bytes:
        if len(self.gid) != GID_SIZE:
            raise ValueError(f"a GID is {GID_SIZE} bytes, not {len(self.gid)}")
        return _ATTACHMENT.pack(self.sequence, self.timestamp_ns, GID_SIZE) + self.gid


def decode_attachment(data: bytes) -> Attachment:
    """An rmw_zenoh attachment; ValueError naming what is wrong when ``data`` is not one."""
    if len(data) != ATTACHMENT_SIZE:
        raise ValueError(f"an rmw_zenoh attachment is {ATTACHMENT_SIZE} bytes, not {len(data)}")
    sequence, stamp, length = _ATTACHMENT.unpack_from(data)
    if length != GID_SIZE:
        raise ValueError(f"an rmw_zenoh attachment's GID is {GID_SIZE} bytes, not {length}")
    return Attachment(sequence, stamp, bytes(data[_ATTACHMENT.size :]))


def chunk(name: str) -> str:
    """``name`` made safe as one key chunk (a client id, a relay id): unsafe characters become ``_``."""
    safe = _UNSAFE.sub("_", name)
    return safe or "_"


def lease_key(prefix: str, robot: str, relay: str, client: str) -> str:
    return f"{prefix}/lease/{chunk(robot)}/{chunk(relay)}/{chunk(client)}"


def lease_selector(prefix: str) -> str:
    return f"{prefix}/lease/*/*/*"


def parse_lease_key(prefix: str, key: str) -> tuple[str, str, str] | None:
    """(robot, relay, client) of a lease token's key; None for any other key."""
    head = f"{prefix}/lease/"
    if not key.startswith(head):
        return None
    parts = key[len(head) :].split("/")
    if len(parts) != 3 or not all(parts):
        return None
    return parts[0], parts[1], parts[2]


def estop_key(prefix: str) -> str:
    return f"{prefix}/estop"


@dataclass(frozen=True, slots=True)
class FleetEstop:
    """An emergency stop sent by ``relay`` for ``robot`` (None: every robot) on behalf of operator ``by``."""

    relay: str
    robot: str | None
    by: str | None

    def encode(self) -> bytes:
        return orjson.dumps({"relay": self.relay, "robot": self.robot, "by": self.by})


def decode_estop(data: bytes) -> FleetEstop:
    """ValueError naming what is wrong when ``data`` is not a fleet estop."""
    try:
        value = orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        raise ValueError(f"a fleet estop is a JSON object, got {len(data)} bytes that are not JSON ({exc})") from None
    if not isinstance(value, dict) or not isinstance(value.get("relay"), str):
        raise ValueError(f"a fleet estop names its relay: got {value!r:.80}")
    robot, by = value.get("robot"), value.get("by")
    if robot is not None and not isinstance(robot, str):
        raise ValueError(f"a fleet estop's robot is a name or null, got {robot!r:.40}")
    return FleetEstop(value["relay"], robot, by if isinstance(by, str) else None)
