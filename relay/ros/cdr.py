"""A hand-written CDR decode of just the pose of a serialized nav_msgs/Odometry, geometry_msgs/PoseStamped or
geometry_msgs/PoseWithCovarianceStamped (what ``raw=True`` subscriptions deliver). The ros backend reads its
pose topics this way: building the whole rclpy message (36 + 36 covariance floats, the twist) costs more than
everything else the relay does with a pose. Measured per Odometry (2 cores, 2026-11-23): rclpy's deserialize
70 us, rosbags' ``deserialize_cdr`` 24 us, this 4.4 us (bench/bench_ros_ingest.py; docs/benchmarks.md). The
other raw topics (TF, scans, images) go through rosbags (relay/backends/ingest.py).

Layout (OMG CDR; XTypes PLAIN_CDR for XCDR1 and PLAIN_CDR2 for XCDR2): a 4-byte encapsulation header
(``00 01`` little-endian XCDR1, ``00 00`` big-endian, ``00 07``/``00 06`` XCDR2), then, aligned relative
to the byte after that header: header.stamp (int32 sec, uint32 nanosec), header.frame_id and
child_frame_id (Odometry only; uint32 length including the NUL, then the bytes), then the pose: position x, y, z and
orientation x, y, z, w as float64 (aligned to 8 in XCDR1, to 4 in XCDR2). The covariance and the twist
that follow are not read. PoseStamped and PoseWithCovarianceStamped are the same up to there without a
child_frame_id (the covariance comes after the pose).
"""

from __future__ import annotations

import struct

from ..fleet.events import PoseEvent

_KINDS = {0x0000: (">", 8), 0x0001: ("<", 8), 0x0006: (">", 4), 0x0007: ("<", 4)}
_STAMP = {order: struct.Struct(order + "iI") for order in "<>"}
_UINT = {order: struct.Struct(order + "I") for order in "<>"}
_POSE = {order: struct.Struct(order + "7d") for order in "<>"}


def _align(offset: int, size: int) -> int:
    # Offsets below are relative to the first byte after the 4-byte encapsulation header.
    return (offset + size - 1) & ~(size - 1)


def stamped_pose(
    data: bytes | memoryview, robot: str = "", *, child_frame: bool = True, received: float = 0.0
) -> PoseEvent:
    """The stamp, frame and pose of a serialized nav_msgs/Odometry (``child_frame``: it has a child_frame_id)
    or PoseStamped / PoseWithCovarianceStamped (not), as ``robot``'s pose event; ValueError when it cannot be one.
    A zero stamp becomes ``received`` and an empty frame "map" only when ``received`` is given (a live graph's
    publishers that leave them unset); otherwise both stay as sent."""
    if len(data) < 16:
        raise ValueError(f"{len(data)} bytes cannot hold a pose message")
    kind = (data[0] << 8) | data[1]
    if kind not in _KINDS:
        raise ValueError(f"unknown CDR encapsulation 0x{kind:04x}")
    order, max_align = _KINDS[kind]
    sec, nanosec = _STAMP[order].unpack_from(data, 4)
    offset = 8  # relative: stamp took 8 bytes
    (length,) = _UINT[order].unpack_from(data, 4 + offset)
    frame_id = bytes(data[4 + offset + 4 : 4 + offset + 4 + max(0, length - 1)]).decode()
    offset = offset + 4 + length
    if child_frame:
        offset = _align(offset, 4)
        (length,) = _UINT[order].unpack_from(data, 4 + offset)
        offset = offset + 4 + length
    offset = _align(offset, min(8, max_align))
    x, y, z, qx, qy, qz, qw = _POSE[order].unpack_from(data, 4 + offset)
    stamp = sec + nanosec * 1e-9
    if received:
        stamp, frame_id = stamp if stamp > 0 else received, frame_id or "map"
    return PoseEvent(robot, stamp, frame_id, x, y, z, qx, qy, qz, qw)


def odometry_pose(data: bytes | memoryview, robot: str = "") -> PoseEvent:
    """The stamp, frame and pose of a serialized nav_msgs/Odometry, as ``robot``'s pose event (the frame is
    the header's, possibly empty; a zero stamp stays zero); ValueError when it is not an Odometry."""
    return stamped_pose(data, robot, child_frame=True)


def cdr_stamp(data: bytes | memoryview, fallback: float | None = None) -> float:
    """Only the header stamp of a serialized message that starts with a std_msgs/Header (every stamped
    type: the least any subscriber must read to know how fresh a message is); a zero stamp is ``fallback``
    when one is given."""
    if len(data) < 12:
        raise ValueError(f"{len(data)} bytes cannot hold a header")
    order = ">" if data[1] in (0x00, 0x06) else "<"
    sec, nanosec = _STAMP[order].unpack_from(data, 4)
    stamp = float(sec + nanosec * 1e-9)
    return fallback if stamp == 0 and fallback is not None else stamp


def odometry_stamp(data: bytes | memoryview) -> float:
    """:func:`cdr_stamp` of an Odometry (the benchmark's bare subscriber reads only this)."""
    return cdr_stamp(data)


def verify(samples: int = 64) -> int:
    """Check :func:`stamped_pose` against rclpy's serializer on Odometry, PoseStamped and
    PoseWithCovarianceStamped messages with frame ids of every length modulo 8 (every alignment case);
    returns how many were checked, raises AssertionError on a mismatch."""
    import math
    import random

    from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message

    rng = random.Random(7)
    checked = 0
    for i in range(samples):
        for cls in (Odometry, PoseStamped, PoseWithCovarianceStamped):
            message = cls()
            message.header.stamp.sec = rng.randint(0, 2**31 - 1)
            message.header.stamp.nanosec = rng.randint(0, 999_999_999)
            message.header.frame_id = "f" * (i % 13)
            pose = message.pose if cls is PoseStamped else message.pose.pose
            if cls is Odometry:
                message.child_frame_id = "c" * ((i * 5) % 11)
            if cls is not PoseStamped:
                message.pose.covariance = [float(k) for k in range(36)]
            p, q = pose.position, pose.orientation
            p.x, p.y, p.z = (rng.uniform(-1e3, 1e3) for _ in range(3))
            q.x, q.y, q.z, q.w = (rng.uniform(-1, 1) for _ in range(4))
            decoded = stamped_pose(serialize_message(message), child_frame=cls is Odometry)
            expected = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
            got = (decoded.x, decoded.y, decoded.z, decoded.qx, decoded.qy, decoded.qz, decoded.qw)
            assert got == expected, (cls.__name__, decoded, expected)
            assert decoded.frame == message.header.frame_id
            stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
            assert math.isclose(decoded.stamp, stamp, rel_tol=0, abs_tol=1e-9), (decoded.stamp, stamp)
            checked += 1
    return checked
