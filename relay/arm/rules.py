"""The arm's safety rules, apart from ROS and sockets: what a hand's twist may ask of an arm, and when it stops.

- **Clamp**: a requested twist is limited to robots.yaml's ``arm.limits`` (the tip's linear speed in m/s and its
  turn rate in rad/s), scaling each vector as a whole so that its direction is kept; a non-finite one is a zero.
- **Refuse** a step (joint positions now and after it) whose tip would leave ``arm.workspace``, whose joint would
  come within ``arm.joint_margin`` of its limit, or whose skeleton would reach into the base's collision box (a
  simple self-collision prediction); the reason names the joint, the bound or the link. Moving away (back into the
  workspace, off a limit, out of the box) is always allowed, so that an arm that got there can leave.
- **Deadman**: no hand command for ``timeout`` seconds while the arm moves: one zero twist is due.
- **E-STOP latch**: while latched every arm motion is refused, until it is reset.

Pure: times are passed in (seconds, the caller's monotonic clock). Tested in tests/test_arm_rules.py.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np

from ..config import Arm, Limits, Workspace
from .kinematics import Values, Vector, forward, points
from .model import ArmModel

Vec3 = tuple[float, float, float]
#: How close (m) the arm's skeleton may come to the base's collision box: MoveIt Servo's
#: ``self_collision_proximity_threshold`` in turtlebot3_manipulation's moveit_servo.yaml.
COLLISION_MARGIN: Final = 0.01
#: The closest the points sampled along a link for the self-collision prediction come (m), however small the margin.
MIN_SPACING: Final = 0.002
_EPSILON = 1e-9  # what counts as moving towards a bound, against rounding


@dataclass(frozen=True, slots=True)
class ClampedTwist:
    linear: Vec3  # m/s
    angular: Vec3  # rad/s
    clamped: bool  # True when either was reduced (or was not finite)


def clamp_twist(linear: Sequence[float], angular: Sequence[float], limits: Limits) -> ClampedTwist:
    """The twist within ``limits``: each vector scaled down as a whole to its limit; non-finite ones are zeros."""
    lin, lin_clamped = _clamp_vector(linear, limits.linear)
    ang, ang_clamped = _clamp_vector(angular, limits.angular)
    return ClampedTwist(lin, ang, lin_clamped or ang_clamped)


def _clamp_vector(vector: Sequence[float], limit: float) -> tuple[Vec3, bool]:
    x, y, z = (float(v) for v in vector)
    if not all(math.isfinite(v) for v in (x, y, z)):
        return (0.0, 0.0, 0.0), True
    norm = math.sqrt(x * x + y * y + z * z)
    if norm <= limit:
        return (x, y, z), False
    scale = limit / norm
    return (x * scale, y * scale, z * scale), True


@dataclass(frozen=True)
class ArmBounds:
    """What a step may not cross: the tip's workspace, the joints' margins, the base's box (plus a margin)."""

    workspace: Workspace
    joint_margin: float
    collision_margin: float = COLLISION_MARGIN

    @classmethod
    def of(cls, arm: Arm) -> ArmBounds:
        return cls(arm.workspace, arm.joint_margin)


def step_refusal(model: ArmModel, before: Values, after: Values, bounds: ArmBounds) -> str | None:
    """Why the arm may not move from joint positions ``before`` to ``after``, or None."""
    q0, q1 = np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)
    return (
        _joint_refusal(model, q0, q1, bounds.joint_margin)
        or _workspace_refusal(model, q0, q1, bounds.workspace)
        or _collision_refusal(model, q0, q1, bounds.collision_margin)
    )


def _joint_refusal(model: ArmModel, q0: Vector, q1: Vector, margin: float) -> str | None:
    for joint, start, end in zip(model.joints, q0, q1, strict=True):
        if end > start + _EPSILON and end > joint.upper - margin:
            return f"{joint.name} would come within {margin:g} of its upper limit {joint.upper:.3f}"
        if end < start - _EPSILON and end < joint.lower + margin:
            return f"{joint.name} would come within {margin:g} of its lower limit {joint.lower:.3f}"
    return None


def _workspace_refusal(model: ArmModel, q0: Vector, q1: Vector, workspace: Workspace) -> str | None:
    tip0, tip1 = forward(model, q0)[:3, 3], forward(model, q1)[:3, 3]
    for axis, name in enumerate("xyz"):
        low, high = workspace.min[axis], workspace.max[axis]
        if tip1[axis] < low and tip1[axis] < tip0[axis] - _EPSILON:
            return f"the tip would leave the workspace: {name} {tip1[axis]:.3f} m is below its min {low:g}"
        if tip1[axis] > high and tip1[axis] > tip0[axis] + _EPSILON:
            return f"the tip would leave the workspace: {name} {tip1[axis]:.3f} m is above its max {high:g}"
    return None


def _collision_refusal(model: ArmModel, q0: Vector, q1: Vector, margin: float) -> str | None:
    """A point of the skeleton that enters the base's box (grown by ``margin``), or goes deeper into it."""
    if not model.base_boxes:
        return None
    skeletons = points(model, q0), points(model, q1)
    # As many points on a link before and after (a prismatic joint changes its length), at most ``margin`` apart: a
    # link that crosses the box then always has a point within ``margin`` of it, inside the grown box.
    longest = np.maximum(*(np.linalg.norm(np.diff(s, axis=0), axis=1) for s in skeletons))
    counts = [max(2, math.ceil(length / max(margin, MIN_SPACING) - _EPSILON) + 1) for length in longest]
    depth0, depth1 = (_depths(model, _samples(s, counts), margin) for s in skeletons)
    worse = (depth1 > 0.0) & (depth1 > depth0 + _EPSILON)
    if not worse.any():
        return None
    link = model.joints[int(np.searchsorted(np.cumsum(counts), int(np.argmax(worse)), side="right"))].child
    return f"self-collision: {link} would come within {margin:g} m of {model.base_link}"


def _samples(skeleton: Vector, counts: list[int]) -> Vector:
    """``counts[i]`` points along the skeleton's i-th segment (the i-th joint's child link), its ends included."""
    return np.concatenate(
        [
            a + np.linspace(0.0, 1.0, count)[:, None] * (b - a)
            for (a, b), count in zip(itertools.pairwise(skeleton), counts, strict=True)
        ]
    )


def _depths(model: ArmModel, samples: Vector, margin: float) -> Vector:
    """How deep each point is inside the deepest box (metres; negative: outside all)."""
    depths = np.full(len(samples), -np.inf)
    for low, high in model.base_boxes:
        inside = np.minimum(samples - (low - margin), (high + margin) - samples).min(axis=1)
        depths = np.maximum(depths, inside)
    return depths


ESTOP_REFUSAL: Final = "estop latched: the arm does not move until the estop is reset"


class ArmGate:
    """One arm's deadman and E-STOP latch. ``feed`` a hand command when it arrives, ``tick`` often (every 20 ms):
    it says when a zero twist is due. Time is passed in."""

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self._latched = False
        self._last: float | None = None  # when the last hand command arrived
        self.moving = False  # the arm was last told a non-zero twist

    @property
    def latched(self) -> bool:
        return self._latched

    def latch(self) -> None:
        """E-STOP: every motion is refused until :meth:`reset`; the caller stops the arm at once."""
        self._latched = True
        self.moving = False

    def reset(self) -> None:
        self._latched = False

    def stopped(self) -> None:
        """The arm was stopped (a rule, a stop): no zero is due until it moves again."""
        self.moving = False

    def feed(self, now: float, moving: bool) -> str | None:
        """A hand command (``moving``: a non-zero twist, a named pose or the gripper) at ``now``: the reason it is
        refused, or None."""
        if self._latched:
            return ESTOP_REFUSAL if moving else None  # a stop always passes
        self._last = now
        self.moving = moving
        return None

    def tick(self, now: float) -> str | None:
        """The reason a zero twist is due now (once per silence), or None."""
        if not self.moving or self._last is None or now - self._last < self.timeout:
            return None
        self.moving = False
        return f"no hand command for {now - self._last:.2f} s (timeout {self.timeout:g} s)"

    def next_deadline(self) -> float | None:
        """When ``tick`` can next say something."""
        return self._last + self.timeout if self.moving and self._last is not None else None
