"""A robot's map-frame pose from TF, without ROS: map->odom composed with odom->base.

Fed with the transforms of ``/tf`` and ``/tf_static`` (from rclpy or from a bag), :class:`TfPose` answers
the pose of ``base_frame`` in ``map_frame``. While no map->odom transform has been seen (no localisation
running), it answers the odom-frame pose and says so in the frame name, rather than nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w


@dataclass(frozen=True, slots=True)
class Transform:
    translation: Vec3
    rotation: Quat


def quat_multiply(a: Quat, b: Quat) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def rotate(q: Quat, v: Vec3) -> Vec3:
    """``v`` rotated by the unit quaternion ``q``."""
    x, y, z, w = q
    vx, vy, vz = v
    # t = 2 * cross(q.xyz, v); v' = v + w * t + cross(q.xyz, t)
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (
        vx + w * tx + (y * tz - z * ty),
        vy + w * ty + (z * tx - x * tz),
        vz + w * tz + (x * ty - y * tx),
    )


def compose(parent: Transform, child: Transform) -> Transform:
    """``parent ∘ child``: the child's frame expressed in the parent's parent frame."""
    tx, ty, tz = rotate(parent.rotation, child.translation)
    px, py, pz = parent.translation
    return Transform((px + tx, py + ty, pz + tz), quat_multiply(parent.rotation, child.rotation))


def strip_slash(frame: str) -> str:
    return frame[1:] if frame.startswith("/") else frame


class TfPose:
    """Tracks the transforms one robot's pose needs; frame names compare without a leading slash."""

    def __init__(self, map_frame: str, odom_frame: str, base_frame: str) -> None:
        self.map_frame = strip_slash(map_frame)
        self.odom_frame = strip_slash(odom_frame)
        self.base_frame = strip_slash(base_frame)
        self._map_odom: Transform | None = None
        self._odom_base: Transform | None = None

    def feed(self, parent: str, child: str, transform: Transform) -> bool:
        """Record one transform; True when it is one this robot's pose depends on."""
        parent, child = strip_slash(parent), strip_slash(child)
        if parent == self.map_frame and child == self.odom_frame:
            self._map_odom = transform
            return True
        if parent == self.odom_frame and child == self.base_frame:
            self._odom_base = transform
            return True
        return False

    def pose(self) -> tuple[str, Transform] | None:
        """(frame, base pose in that frame): the map frame once map->odom is known, else odom."""
        if self._odom_base is None:
            return None
        if self._map_odom is None:
            return self.odom_frame, self._odom_base
        return self.map_frame, compose(self._map_odom, self._odom_base)
