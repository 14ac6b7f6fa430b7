"""Forward kinematics, a Cartesian velocity step and position inverse kinematics of an :class:`ArmModel` (numpy).

Everything is in the arm's base link frame (MoveIt Servo's ``planning_frame``; ``base_link`` on the TurtleBot3
with OpenManipulator-X), metres and radians. Joint positions are arrays in the chain's order.

Position comes first. OpenManipulator-X has four joints, so of a hand's six-dimensional motion only the position
and one turn (the gripper's pitch) can be followed at once; its yaw comes with its position. The velocity step
follows the linear velocity (a damped least-squares solution on the position rows of the geometric Jacobian) and
then as much of the angular velocity as the remaining joint freedom allows (the same, in the null space of the
position task). Inverse kinematics solves for position only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .model import ArmModel, Transform

Vector = NDArray[np.float64]
#: Joint positions (or a point, a velocity): a sequence of floats or an array.
Values = Sequence[float] | Vector

#: Damping of the position task (metres): about a tenth of a link's length, so that near a singularity (the arm
#: stretched out) joint speeds stay bounded instead of growing without limit; far from one it changes little.
POSITION_DAMPING = 0.02
#: Damping of the orientation task (radians of tip turn per radian of joint turn, about 1 for a revolute joint).
ORIENTATION_DAMPING = 0.1
#: Inverse kinematics: the largest joint change per iteration (rad or m), and the tolerance of a solution (m).
IK_STEP = 0.2
IK_TOLERANCE = 1e-4
IK_ITERATIONS = 200


@dataclass(frozen=True, eq=False)
class Step:
    positions: Vector  # after ``dt``, within the joint limits
    velocities: Vector  # what moved the joints there (the clipped velocities; less at a joint limit)


def frames(model: ArmModel, q: Values) -> tuple[list[Transform], Transform]:
    """Each joint's frame in the base frame (its axis passes through its origin) and the tip's pose."""
    current = np.eye(4)
    out = []
    for joint, position in zip(model.joints, np.asarray(q, dtype=np.float64), strict=True):
        current = current @ joint.origin
        out.append(current)
        current = current @ _motion(joint.kind, joint.axis, float(position))
    return out, current @ model.tip


def forward(model: ArmModel, q: Values) -> Transform:
    """The tip's pose (4x4) in the base frame at joint positions ``q``."""
    return frames(model, q)[1]


def points(model: ArmModel, q: Values) -> Vector:
    """The origins of the joints' frames and the tip, shape (joints + 1, 3): the arm's skeleton."""
    joint_frames, tip = frames(model, q)
    return np.array([f[:3, 3] for f in [*joint_frames, tip]])


def jacobian(model: ArmModel, q: Values) -> Vector:
    """The geometric Jacobian (6 x joints) at the tip, in the base frame: rows vx, vy, vz, wx, wy, wz."""
    joint_frames, tip = frames(model, q)
    columns = []
    for joint, frame in zip(model.joints, joint_frames, strict=True):
        axis = frame[:3, :3] @ joint.axis
        if joint.kind == "revolute":
            columns.append(np.concatenate([np.cross(axis, tip[:3, 3] - frame[:3, 3]), axis]))
        else:
            columns.append(np.concatenate([axis, np.zeros(3)]))
    return np.array(columns).T


def velocity_step(model: ArmModel, q: Values, linear: Values, angular: Values, dt: float) -> Step:
    """The joints after following a twist (``linear`` m/s, ``angular`` rad/s, base frame) for ``dt`` seconds.

    Position first, then orientation in what is left (the module's docstring). The joint velocities are scaled
    down together until each is within its limit (which keeps the tip's direction, where clipping each joint alone
    would bend it), and the positions are clipped to the joint limits.
    """
    q = np.asarray(q, dtype=np.float64)
    jac = jacobian(model, q)
    jp, jo = jac[:3], jac[3:]
    n = len(q)
    jp_inv = _damped_inverse(jp, POSITION_DAMPING)
    qdot = jp_inv @ np.asarray(linear, dtype=np.float64)
    null = _null_projector(jp)
    turn = _damped_inverse(jo @ null, ORIENTATION_DAMPING) @ (np.asarray(angular, dtype=np.float64) - jo @ qdot)
    qdot = qdot + null @ turn
    ratio = float(np.max(np.abs(qdot) / model.velocity))
    if ratio > 1.0:
        qdot = qdot / ratio
    positions = np.clip(q + qdot * dt, model.lower, model.upper)
    velocities = (positions - q) / dt if dt > 0.0 else np.zeros(n)
    return Step(positions, velocities)


def inverse(
    model: ArmModel,
    target: Values,
    start: Values | None = None,
    iterations: int = IK_ITERATIONS,
) -> Vector | None:
    """Joint positions within the limits that put the tip at ``target`` (x, y, z in the base frame) within
    :data:`IK_TOLERANCE`, or None when it is out of reach. Damped least squares from ``start`` (else the middle of
    the limits), then from two other seeds; at most ``iterations`` steps from each."""
    goal = np.asarray(target, dtype=np.float64)
    if not _within_reach(model, goal):
        return None
    bounded = np.isfinite(model.lower) & np.isfinite(model.upper)
    middle: Vector = (np.where(bounded, model.lower, 0.0) + np.where(bounded, model.upper, 0.0)) / 2.0  # 0: unbounded
    seeds = [np.zeros(len(model.joints)), middle] if start is None else [np.asarray(start, dtype=np.float64)]
    seeds += [np.clip(middle + offset, model.lower, model.upper) for offset in (0.7, -0.7)]
    for seed in seeds:
        q: Vector = np.clip(seed, model.lower, model.upper)
        for _ in range(iterations):
            error = goal - forward(model, q)[:3, 3]
            if float(np.linalg.norm(error)) < IK_TOLERANCE:
                return q
            dq = _damped_inverse(jacobian(model, q)[:3], POSITION_DAMPING / 4.0) @ error
            largest = float(np.max(np.abs(dq)))
            if largest > IK_STEP:
                dq *= IK_STEP / largest
            q = np.clip(q + dq, model.lower, model.upper)
    return None


def _within_reach(model: ArmModel, goal: Vector) -> bool:
    """False when ``goal`` is farther from the first joint than the skeleton's length (links and prismatic travel):
    no iteration could get there."""
    skeleton = points(model, np.clip(np.zeros(len(model.joints)), model.lower, model.upper))
    length = float(np.sum(np.linalg.norm(np.diff(skeleton, axis=0), axis=1)))
    length += sum(j.upper - j.lower for j in model.joints if j.kind == "prismatic")
    return float(np.linalg.norm(goal - skeleton[0])) <= length


def _null_projector(matrix: Vector) -> Vector:
    """The projection onto the joint motions that ``matrix`` maps to zero (exact, from the SVD): what the
    orientation task may use without moving the tip."""
    _, singular, vt = np.linalg.svd(matrix)
    rank = int(np.sum(singular > 1e-9))
    basis = vt[rank:].T
    projector: Vector = basis @ basis.T
    return projector


def _damped_inverse(matrix: Vector, damping: float) -> Vector:
    """``A^T (A A^T + d^2 I)^-1``: the least-squares inverse that trades exactness for bounded norm near a
    singularity."""
    rows = matrix.shape[0]
    inverse_: Vector = matrix.T @ np.linalg.inv(matrix @ matrix.T + damping**2 * np.eye(rows))
    return inverse_


def _motion(kind: str, axis: Vector, position: float) -> Transform:
    """The joint's own transform at ``position``: a turn about ``axis`` (Rodrigues) or a slide along it."""
    motion = np.eye(4)
    if kind == "prismatic":
        motion[:3, 3] = axis * position
        return motion
    x, y, z = axis
    skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    motion[:3, :3] = np.eye(3) + np.sin(position) * skew + (1.0 - np.cos(position)) * (skew @ skew)
    return motion
