"""Small planar geometry helpers in ROS conventions (REP 103: z up, yaw counter-clockwise from +x)."""

from __future__ import annotations

import math


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion ``(qx, qy, qz, qw)`` of a rotation by ``yaw`` about +z."""
    half = 0.5 * yaw
    return 0.0, 0.0, math.sin(half), math.cos(half)


def quaternion_to_yaw(qx: float, qy: float, qz: float, qw: float) -> float:
    """Yaw (rotation about +z) of a quaternion, in (-pi, pi]."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped into (-pi, pi]."""
    wrapped = math.remainder(angle, math.tau)
    return math.pi if wrapped == -math.pi else wrapped
