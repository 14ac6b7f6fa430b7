"""A hand-written CDR decode of just the pose of a serialized nav_msgs/Odometry (what ``raw=True``
subscriptions deliver). The ros backend reads Odometry poses this way: building the whole rclpy message
(36 + 36 covariance floats, the twist) costs more than everything else the relay does with a pose
(bench/bench_ros_ingest.py; docs/benchmarks.md).

Layout (OMG CDR; XTypes PLAIN_CDR for XCDR1 and PLAIN_CDR2 for XCDR2): a 4-byte encapsulation header
(``00 01`` little-endian XCDR1, ``00 00`` big-endian, ``00 07``/``00 06`` XCDR2), then, aligned relative
to the byte after that header: header.stamp (int32 sec, uint32 nanosec), header.frame_id and
child_frame_id (uint32 length including the NUL, then the bytes), then pose.pose: position x, y, z and
orientation x, y, z, w as float64 (aligned to 8 in XCDR1, to 4 in XCDR2). The covariance and the twist
that follow are not read.
"""

from __future__ import annotations

import struct

from .events import PoseEvent

_KINDS = {0x0000: (">", 8), 0x0001: ("<", 8), 0x0006: (">", 4), 0x0007: ("<", 4)}
_STAMP = {order: struct.Struct(order + "iI") for order in "<>"}
_UINT = {order: struct.Struct(order + "I") for order in "<>"}
_POSE = {order: struct.Struct(order + "7d") for order in "<>"}


def _align(offset: int, size: int) -> int:
    # Offsets below are relative to the first byte after the 4-byte encapsulation header.
    return (offset + size - 1) & ~(size - 1)


def odometry_pose(data: bytes | memoryview, robot: str = "") -> PoseEvent:
    """The stamp, frame and pose of a serialized nav_msgs/Odometry, as ``robot``'s pose event (the frame is
    the header's, possibly empty; a zero stamp stays zero); ValueError when it is not an Odometry."""
    if len(data) < 16:
        raise ValueError(f"{len(data)} bytes cannot hold an Odometry")
    kind = (data[0] << 8) | data[1]
    if kind not in _KINDS:
        raise ValueError(f"unknown CDR encapsulation 0x{kind:04x}")
    order, max_align = _KINDS[kind]
    sec, nanosec = _STAMP[order].unpack_from(data, 4)
    offset = 8  # relative: stamp took 8 bytes
    (length,) = _UINT[order].unpack_from(data, 4 + offset)
    frame_id = bytes(data[4 + offset + 4 : 4 + offset + 4 + max(0, length - 1)]).decode()
    offset = _align(offset + 4 + length, 4)
    (length,) = _UINT[order].unpack_from(data, 4 + offset)
    offset = _align(offset + 4 + length, min(8, max_align))
    x, y, z, qx, qy, qz, qw = _POSE[order].unpack_from(data, 4 + offset)
    return PoseEvent(robot, sec + nanosec * 1e-9, frame_id, x, y, z, qx, qy, qz, qw)


def odometry_stamp(data: bytes | memoryview) -> float:
    """Only the header stamp (the least any subscriber must read to know how fresh a message is)."""
    order = ">" if data[1] in (0x00, 0x06) else "<"
    sec, nanosec = _STAMP[order].unpack_from(data, 4)
    return float(sec + nanosec * 1e-9)


def verify(samples: int = 64) -> int:
    """Check :func:`odometry_pose` against rclpy's serializer on messages with frame ids of every length
    modulo 8 (every alignment case); returns how many were checked, raises AssertionError on a mismatch."""
    import math
    import random

    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message

    rng = random.Random(7)
    checked = 0
    for i in range(samples):
        message = Odometry()
        message.header.stamp.sec = rng.randint(0, 2**31 - 1)
        message.header.stamp.nanosec = rng.randint(0, 999_999_999)
        message.header.frame_id = "f" * (i % 13)
        message.child_frame_id = "c" * ((i * 5) % 11)
        p, q = message.pose.pose.position, message.pose.pose.orientation
        p.x, p.y, p.z = (rng.uniform(-1e3, 1e3) for _ in range(3))
        q.x, q.y, q.z, q.w = (rng.uniform(-1, 1) for _ in range(4))
        message.pose.covariance = [float(k) for k in range(36)]
        decoded = odometry_pose(serialize_message(message))
        expected = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
        got = (decoded.x, decoded.y, decoded.z, decoded.qx, decoded.qy, decoded.qz, decoded.qw)
        assert got == expected, (decoded, expected)
        assert decoded.frame == message.header.frame_id
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        assert math.isclose(decoded.stamp, stamp, rel_tol=0, abs_tol=1e-9), (decoded.stamp, stamp)
        checked += 1
    return checked
