"""A robot's map-frame pose from recorded TF, through the static tree (relay.ros.tf.TfPose does map->odom->base)."""

from __future__ import annotations

import logging
from typing import Any

from ...config import Robot
from ...fleet.events import (
    PoseEvent,
)
from ...ros.rosmsg import (
    header_stamp,
    transform_of,
)
from ...ros.tf import TfPose, Transform, compose, rotate, strip_slash

logger = logging.getLogger(__name__)

#: TF messages seen without one transform of a robot's chain before the reader says which frames it saw.
TF_DIAGNOSIS_AFTER = 200


IDENTITY = Transform((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def inverse(transform: Transform) -> Transform:
    x, y, z, w = transform.rotation
    conjugate = (-x, -y, -z, w)
    tx, ty, tz = rotate(conjugate, transform.translation)
    return Transform((-tx, -ty, -tz), conjugate)


class _TfChain:
    """One robot's pose from TF: map->odom composed with odom->X and X's static path to the base frame.

    The recording's base frame need not be the configured one: a TurtleBot3 publishes odom->base_footprint,
    a TurtleBot4 odom->base_link, and /tf_static links the two either way. Reader thread only.
    """

    def __init__(self, robot: Robot) -> None:
        self.robot = robot.name
        spec = robot.pose
        self.map_frame = strip_slash(spec.map_frame)
        self.odom_frame = strip_slash(spec.odom_frame)
        self.base_frame = strip_slash(spec.base_frame)
        self._statics: dict[str, tuple[str, Transform]] = {}  # child -> (parent, child's pose in parent)
        self._links: dict[str, Transform | None] = {}  # frame -> base's pose in it, through the statics
        self._seen: set[tuple[str, str]] = set()
        self._idle = 0
        self._diagnosed = False
        self.reset()

    def reset(self) -> None:
        """Forget the moving transforms (a seek); the static ones stay."""
        self._tracker = TfPose(self.map_frame, self.odom_frame, self.base_frame)
        self._stamp: float | None = None

    def add_static(self, message: Any) -> None:
        for t in message.transforms:
            parent, child = strip_slash(t.header.frame_id), strip_slash(t.child_frame_id)
            self._statics[child] = (parent, transform_of(t))
        self._links.clear()

    def _ancestors(self, frame: str) -> dict[str, Transform]:
        """``frame``'s pose in itself and in each of its static ancestors, nearest first."""
        result = {frame: IDENTITY}
        pose, current = IDENTITY, frame
        while current in self._statics:
            parent, transform = self._statics[current]
            if parent in result:  # a cycle in a broken recording
                break
            pose = compose(transform, pose)
            result[parent] = pose
            current = parent
        return result

    def _link(self, frame: str) -> Transform | None:
        """The base frame's pose in ``frame`` through the static tree, or None when they are not linked."""
        if frame not in self._links:
            link = None
            of_frame = self._ancestors(frame)
            for ancestor, base_in_ancestor in self._ancestors(self.base_frame).items():
                if ancestor in of_frame:
                    link = compose(inverse(of_frame[ancestor]), base_in_ancestor)
                    break
            self._links[frame] = link
        return self._links[frame]

    def feed(self, message: Any, log_time: float) -> PoseEvent | None:
        """One TFMessage; the robot's pose when it changed the chain."""
        changed = False
        for t in message.transforms:
            parent, child = strip_slash(t.header.frame_id), strip_slash(t.child_frame_id)
            if parent == self.map_frame and child == self.odom_frame:
                changed = self._tracker.feed(parent, child, transform_of(t)) or changed
            elif parent == self.odom_frame:
                link = self._link(child)
                if link is None:
                    self._seen.add((parent, child))
                    continue
                self._tracker.feed(parent, self.base_frame, compose(transform_of(t), link))
                # The pose is as old as the robot's motion: AMCL stamps map->odom into the future.
                self._stamp = header_stamp(t.header, log_time)
                changed = True
            else:
                self._seen.add((parent, child))
        result = self._tracker.pose() if changed else None
        if result is None:
            self._diagnose()
            return None
        self._idle = 0
        frame, pose = result
        (x, y, z), (qx, qy, qz, qw) = pose.translation, pose.rotation
        stamp = self._stamp if self._stamp is not None else log_time
        return PoseEvent(self.robot, stamp, frame, x, y, z, qx, qy, qz, qw)

    def _diagnose(self) -> None:
        self._idle += 1
        if self._idle >= TF_DIAGNOSIS_AFTER and not self._diagnosed:
            self._diagnosed = True
            seen = ", ".join(f"{p}->{c}" for p, c in sorted(self._seen)[:12]) or "none"
            logger.warning(
                "%s: TF has no %s->%s (directly or through /tf_static) after %d messages; transforms seen: %s. "
                "Set pose.odom_frame and pose.base_frame in robots.yaml to the recording's frames",
                self.robot,
                self.odom_frame,
                self.base_frame,
                self._idle,
                seen,
            )
