"""Where a robot's sensor was in the map when it took a cloud: the robot's pose at the cloud's stamp composed with the
sensor's place on the robot. Pure (no I/O, no clock, no lock: callers own the thread).

**The robot's pose at a stamp** comes from the history of its poses (:class:`PoseHistory`: whatever its pose source
gives, TF, odometry, AMCL or a PoseStamped, in the map frame once localised), interpolated between the two around
the stamp (linear in position, normalised linear in the quaternion: poses come tens of milliseconds apart). A stamp
up to :data:`HOLD` seconds outside the history takes the nearest pose (a sensor stamped a little after the newest
odometry); further, it is a :class:`~relay.cloud.errors.CloudError` naming the stamp and the poses known: tf2 does
not extrapolate either (:class:`NotYet` when the cloud is newer than every pose: its caller may wait for one).

**The sensor on the robot** is robots.yaml's ``mount`` when it has one, else the message's frame through the static
transforms (/tf_static: base_link -> camera_link -> camera_depth_optical_frame) to the robot's base frame. A cloud
already in the map frame needs neither. No path is a CloudError naming both frames and how to give one.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from typing import Final

import numpy as np
from numpy.typing import NDArray

from .errors import CloudError, shown

#: Seconds a pose is held past the newest (or before the oldest) of the history.
HOLD: Final = 0.5
#: Poses kept per robot: 60 s at 30 Hz (a bag is read up to 10 s ahead of its playback).
HISTORY: Final = 1800
#: A pose this much older than the newest starts the history again (a bag seeked back, or looped).
REWIND: Final = 1.0

Matrix = NDArray[np.float64]


def matrix(translation: Sequence[float], rotation: Sequence[float]) -> Matrix:
    """The 4x4 homogeneous transform of a translation and a quaternion ``(x, y, z, w)`` (normalised here)."""
    x, y, z, w = (float(v) for v in rotation)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 0 or not math.isfinite(norm):
        raise CloudError(f"rotation {tuple(rotation)} is not a quaternion")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    m = np.eye(4)
    m[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    m[:3, 3] = [float(v) for v in translation]
    return m


def rpy_matrix(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> Matrix:
    """URDF's origin: rotations about the parent's fixed x, y, z axes in that order, then the translation."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    m = np.eye(4)
    m[:3, :3] = [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
    m[:3, 3] = [x, y, z]
    return m


def strip_slash(frame: str) -> str:
    return frame[1:] if frame.startswith("/") else frame


class NotYet(CloudError):
    """The cloud is newer than the robot's newest pose: a pose at its stamp may still come (it travels apart)."""


class PoseHistory:
    """One robot's recent poses by stamp, oldest first."""

    def __init__(self) -> None:
        self._stamps: deque[float] = deque(maxlen=HISTORY)
        self._poses: deque[tuple[tuple[float, float, float], tuple[float, float, float, float]]] = deque(maxlen=HISTORY)

    def __len__(self) -> int:
        return len(self._stamps)

    def add(
        self, stamp: float, translation: tuple[float, float, float], rotation: tuple[float, float, float, float]
    ) -> None:
        if self._stamps and stamp < self._stamps[-1]:
            if stamp < self._stamps[-1] - REWIND:
                self._stamps.clear()
                self._poses.clear()
            else:
                return  # a late one among poses already newer: the history stays in order
        self._stamps.append(stamp)
        self._poses.append((translation, rotation))

    def clear(self) -> None:
        self._stamps.clear()
        self._poses.clear()

    def at(self, stamp: float) -> Matrix:
        """The pose at ``stamp``; a CloudError when the history does not reach it."""
        stamps = self._stamps
        if not stamps:
            raise CloudError(f"no pose of the robot yet (at the cloud's stamp {stamp:.3f})")
        first, last = stamps[0], stamps[-1]
        if stamp <= first or stamp >= last:
            if not first - HOLD <= stamp <= last + HOLD:
                raise (NotYet if stamp > last else CloudError)(
                    f"no transform at the cloud's stamp {stamp:.3f}: the robot's poses known are from {first:.3f} to "
                    f"{last:.3f} (held {HOLD:g} s at most)"
                )
            return matrix(*self._poses[0 if stamp <= first else -1])
        index = int(np.searchsorted(np.fromiter(stamps, float, len(stamps)), stamp))  # stamps[index-1] < stamp <= ...
        (t0, q0), (t1, q1) = self._poses[index - 1], self._poses[index]
        f = (stamp - stamps[index - 1]) / (stamps[index] - stamps[index - 1])
        if sum(a * b for a, b in zip(q0, q1, strict=True)) < 0:  # the same rotation's other sign: the short way
            q1 = (-q1[0], -q1[1], -q1[2], -q1[3])
        translation = [a + (b - a) * f for a, b in zip(t0, t1, strict=True)]
        rotation = [a + (b - a) * f for a, b in zip(q0, q1, strict=True)]
        return matrix(translation, rotation)


class StaticTree:
    """The static transforms (/tf_static) of one robot: each child frame's pose in its parent."""

    def __init__(self) -> None:
        self._parents: dict[str, tuple[str, Matrix]] = {}

    def add(self, parent: str, child: str, transform: Matrix) -> None:
        self._parents[strip_slash(child)] = (strip_slash(parent), transform)

    def _ancestors(self, frame: str) -> dict[str, Matrix]:
        """``frame``'s pose in itself and in each of its ancestors."""
        result = {frame: np.eye(4)}
        pose, current = np.eye(4), frame
        while current in self._parents:
            parent, transform = self._parents[current]
            if parent in result:  # a cycle in a broken graph
                break
            pose = transform @ pose
            result[parent] = pose
            current = parent
        return result

    def link(self, frame: str, base: str) -> Matrix | None:
        """``frame``'s pose in ``base`` through the static transforms, or None when they are not linked."""
        of_frame = self._ancestors(frame)
        for ancestor, base_in_ancestor in self._ancestors(base).items():
            if ancestor in of_frame:
                return np.linalg.inv(base_in_ancestor) @ of_frame[ancestor]
        return None


class Placement:
    """One robot's poses and static transforms, and the sensor's pose in the map they give at a stamp."""

    def __init__(self, map_frame: str, base_frame: str) -> None:
        self.map_frame = strip_slash(map_frame)
        self.base_frame = strip_slash(base_frame)
        self.poses = PoseHistory()
        self.statics = StaticTree()

    def sensor(self, frame: str, stamp: float, mount: Matrix | None = None) -> Matrix:
        """The pose in the map of the sensor frame ``frame`` at ``stamp`` (``mount``: its pose on the base)."""
        frame = strip_slash(frame)
        if mount is None:
            if frame == self.map_frame:
                return np.eye(4)
            if not frame or frame == self.base_frame:
                mount = np.eye(4)
            else:
                mount = self.statics.link(frame, self.base_frame)
                if mount is None:
                    raise CloudError(
                        f"no transform from frame {shown(frame)} to the robot's base frame {shown(self.base_frame)}: "
                        "none in /tf_static; give the cloud a mount in robots.yaml"
                    )
        return self.poses.at(stamp) @ mount
