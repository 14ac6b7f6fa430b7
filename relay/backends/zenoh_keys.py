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
when the relay holding it goes away; ``<prefix>/heartbeat/<relay-id>`` lists, every second, the leases a relay holds
(a token counts only while they do). What another relay sends is checked field by field like a client's frame.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import Literal

import orjson

from ..session.protocol import NAME_PATTERN, ROBOT_NAME_PATTERN
from ..wire.fields import show

KeyStyle = Literal["rmw_zenoh", "bridge"]

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


def parse_lease_key(prefix: str, key: str) -> tuple[str, str, str]:
    """(robot, relay, client) of a lease token's key; ValueError naming what is wrong for any other key."""
    head = f"{prefix}/lease/"
    parts = key[len(head) :].split("/", 3) if key.startswith(head) else []
    if len(parts) != 3:
        raise ValueError(f"a lease token is {head}<robot>/<relay>/<client>, got {show_key(key)}")
    robot, relay, client = parts
    _name(robot, "its robot", ROBOT_NAME_PATTERN)
    _name(relay, "its relay", PEER_NAME)
    _name(client, "its client", PEER_NAME)
    return robot, relay, client


def estop_key(prefix: str) -> str:
    return f"{prefix}/estop"


def heartbeat_key(prefix: str, relay: str) -> str:
    return f"{prefix}/heartbeat/{chunk(relay)}"


def heartbeat_selector(prefix: str) -> str:
    return f"{prefix}/heartbeat/*"


# -- what another relay sends, checked as a client's frame is (relay/session/protocol.py) ------------------------------
# Another relay's sample is input like a client's frame: each field has a type and a bounded length, and a bad
# one is refused whole, with a message that shows it clipped (fields.show). A rogue peer's estop of 200 kB
# fields once reached every client as a 400 kB message and wrote 800 kB to the log (issue 28).

#: A relay's id or a client's as they appear in keys and samples: letters, digits, ``_ . -`` (a Zenoh session id
#: is 32 hex digits, a client id ``c12-3f9a0b``).
PEER_NAME = re.compile(r"^[\w.-]{1,64}$")
_PEER_TEXT = "a name of 1 to 64 letters, digits, _ . or -"
_ROBOT_TEXT = "a robot's name (a letter, then up to 63 letters, digits or _)"
#: Who made an estop (a client id today; an operator's name would pass too), as relay/session/protocol.py's names.
MAX_BY_LENGTH = 64
#: A fleet estop is ~90 bytes; a heartbeat ~140 bytes per lease listed.
MAX_ESTOP_BYTES = 1024
MAX_HEARTBEAT_BYTES = 64 * 1024
#: Leases one heartbeat may list (more robots than one relay serves in practice).
MAX_HEARTBEAT_LEASES = 256


#: A key shown in a message: an rmw_zenoh key with its type and RIHS01 hash is ~120 characters; one longer is
#: made up, and clipped.
MAX_KEY_SHOWN = 160


def show_key(key: str) -> str:
    return key if len(key) <= MAX_KEY_SHOWN else key[: MAX_KEY_SHOWN - 3] + "..."


def _show(value: object) -> str:
    """A bad value, clipped (relay/session/protocol.py's rendering; a nested one by its size: it may be too deep to
    print)."""
    if isinstance(value, dict | list):
        return f"a JSON {'object' if isinstance(value, dict) else 'array'} of {len(value)} items"
    return show(value)


def _name(value: object, what: str, pattern: re.Pattern[str]) -> str:
    if not isinstance(value, str) or not pattern.fullmatch(value):
        expected = _ROBOT_TEXT if pattern is ROBOT_NAME_PATTERN else _PEER_TEXT
        raise ValueError(f"{what} must be {expected}, got {_show(value)}")
    return value


def _is_operator(by: str) -> bool:
    return len(by) <= MAX_BY_LENGTH and NAME_PATTERN.fullmatch(by) is not None


def _json_object(data: bytes, limit: int, what: str) -> dict[str, object]:
    if len(data) > limit:
        raise ValueError(f"{what} is at most {limit} bytes, got {len(data)}")
    try:
        value = orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        raise ValueError(
            f"{what} is a JSON object, got {len(data)} bytes that are not JSON ({_show(str(exc))})"
        ) from None
    if not isinstance(value, dict):
        raise ValueError(f"{what} is a JSON object, got {_show(value)}")
    return value


@dataclass(frozen=True, slots=True)
class FleetEstop:
    """An emergency stop sent by ``relay`` for ``robot`` (None: every robot) on behalf of operator ``by``."""

    relay: str
    robot: str | None
    by: str | None

    def encode(self) -> bytes:
        # Who made it is a courtesy; the stop is not: a name the others would refuse goes as null.
        by = self.by if self.by is None or _is_operator(self.by) else None
        return orjson.dumps({"relay": self.relay, "robot": self.robot, "by": by})


def decode_estop(data: bytes) -> FleetEstop:
    """ValueError naming what is wrong when ``data`` is not a fleet estop."""
    value = _json_object(data, MAX_ESTOP_BYTES, "a fleet estop")
    if "relay" not in value:
        raise ValueError(f"a fleet estop names its relay: got {_show(value)}")
    relay = _name(value["relay"], "a fleet estop's relay", PEER_NAME)
    robot = value.get("robot")
    if robot is not None and (not isinstance(robot, str) or not ROBOT_NAME_PATTERN.fullmatch(robot)):
        raise ValueError(f"a fleet estop's robot is a name or null, got {_show(robot)}")
    by = value.get("by")
    if by is not None and (not isinstance(by, str) or not _is_operator(by)):
        raise ValueError(
            f"a fleet estop's by is an operator of 1 to {MAX_BY_LENGTH} characters or null, got {_show(by)}"
        )
    return FleetEstop(relay, robot, by)


@dataclass(frozen=True, slots=True)
class FleetHeartbeat:
    """``relay`` is alive and holds these leases (robot -> client): sent every second and at each change. A lease
    token counts only while its relay's heartbeats list it (relay/control/fleet_peer.py, :class:`PeerLeases`)."""

    relay: str
    leases: dict[str, str]

    def encode(self) -> bytes:
        return orjson.dumps({"relay": self.relay, "leases": {robot: chunk(c) for robot, c in self.leases.items()}})


def decode_heartbeat(prefix: str, key: str, data: bytes) -> FleetHeartbeat:
    """A heartbeat sample (its key names the same relay as its body); ValueError naming what is wrong."""
    value = _json_object(data, MAX_HEARTBEAT_BYTES, "a fleet heartbeat")
    relay = _name(value.get("relay"), "a fleet heartbeat's relay", PEER_NAME)
    if key != heartbeat_key(prefix, relay):
        raise ValueError(
            f"a fleet heartbeat of relay {relay} goes on {heartbeat_key(prefix, relay)}, got {show_key(key)}"
        )
    leases = value.get("leases")
    if not isinstance(leases, dict) or len(leases) > MAX_HEARTBEAT_LEASES:
        raise ValueError(
            f"a fleet heartbeat's leases map up to {MAX_HEARTBEAT_LEASES} robots to clients, got {_show(leases)}"
        )
    for robot, client in leases.items():
        _name(robot, "a fleet heartbeat's robot", ROBOT_NAME_PATTERN)
        _name(client, f"the client of {robot} in a fleet heartbeat", PEER_NAME)
    return FleetHeartbeat(relay, dict(leases))
