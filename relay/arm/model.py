"""An arm's kinematic chain, read from a URDF: the joints that move between a base link and a tip link.

The chain is the path of joints from ``base_link`` down to ``tip_link``; fixed joints on it are folded into the
origin of the next moving joint (or into the tip's offset), so only revolute and prismatic joints remain, each with
its axis, its origin and the position and velocity limits the URDF gives. The gripper joint is kept apart, with the
joints that mimic it (OpenManipulator-X: ``gripper_right_joint`` mimics ``gripper_left_joint``). The base link's
collision boxes are kept as the body the arm must not reach into (relay.arm.rules). MoveIt's joint_limits.yaml may
narrow the joints' limits (:func:`with_joint_limits`).

Loading reads and parses a file (or a robot_description string) with yourdfpy, without meshes: it blocks for
tens of milliseconds, so call it off the event loop (``asyncio.to_thread``).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from numpy.typing import NDArray

from ..twin.urdf.errors import RobotModelError
from ..twin.urdf.parse import parse_urdf, substitute_namespace

#: A 4x4 homogeneous transform (metres).
Transform = NDArray[np.float64]
JointKind = Literal["revolute", "prismatic"]


@dataclass(frozen=True, eq=False)
class ArmJoint:
    """A joint of the chain. ``origin`` leads from the previous joint's frame (after its motion), or from the base
    link for the first joint, to this joint's frame at position 0; ``axis`` is a unit vector in that frame."""

    name: str
    kind: JointKind
    child: str  # the link it moves
    origin: Transform
    axis: NDArray[np.float64]
    lower: float  # rad or m
    upper: float
    velocity: float  # the URDF's velocity limit, rad/s or m/s


@dataclass(frozen=True)
class GripperJoint:
    name: str
    kind: JointKind
    lower: float
    upper: float
    velocity: float
    #: Joints that follow it (their <mimic> names it): (name, multiplier, offset), at multiplier * position + offset.
    mimics: tuple[tuple[str, float, float], ...]


@dataclass(frozen=True, eq=False)
class ArmModel:
    base_link: str
    tip_link: str
    joints: tuple[ArmJoint, ...]
    tip: Transform  # from the last joint's frame (after its motion) to the tip link
    gripper: GripperJoint | None
    #: The base link's collision boxes as axis-aligned (min corner, max corner) in the base link's frame.
    base_boxes: tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def lower(self) -> NDArray[np.float64]:
        return np.array([j.lower for j in self.joints])

    @property
    def upper(self) -> NDArray[np.float64]:
        return np.array([j.upper for j in self.joints])

    @property
    def velocity(self) -> NDArray[np.float64]:
        return np.array([j.velocity for j in self.joints])


def load_arm(path: str | Path, base_link: str, tip_link: str, gripper_joint: str | None = None) -> ArmModel:
    """The arm of the URDF file at ``path`` (blocking: it reads the file). RobotModelError says what is wrong."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise RobotModelError(f"cannot read the URDF {path}: {err}") from err
    return arm_from_urdf(text, base_link, tip_link, gripper_joint)


def arm_from_urdf(urdf_text: str, base_link: str, tip_link: str, gripper_joint: str | None = None) -> ArmModel:
    """The arm between ``base_link`` and ``tip_link`` of a URDF document (a file's text or a robot_description);
    ``${namespace}`` placeholders are removed. Blocking (parsing); RobotModelError names what is missing."""
    urdf = parse_urdf(substitute_namespace(urdf_text))
    by_child = {j.child: j for j in urdf.robot.joints}
    links = {link.name: link for link in urdf.robot.links}
    for role, link_name in (("base_link", base_link), ("tip_link", tip_link)):
        if link_name not in links:
            raise RobotModelError(f"{role} {link_name!r} is not a link of the URDF")
    path = []
    link = tip_link
    while link != base_link:
        if link not in by_child:
            raise RobotModelError(f"tip_link {tip_link!r} is not below base_link {base_link!r} in the URDF")
        path.append(by_child[link])
        link = by_child[link].parent
    joints: list[ArmJoint] = []
    pending = np.eye(4)  # fixed joints since the last moving one
    for joint in reversed(path):
        origin = _origin(joint)
        if joint.type == "fixed":
            pending = pending @ origin
            continue
        joints.append(_arm_joint(joint, pending @ origin))
        pending = np.eye(4)
    if not joints:
        raise RobotModelError(f"no revolute or prismatic joint between {base_link!r} and {tip_link!r}")
    gripper = _gripper(urdf.robot.joints, gripper_joint, {j.name for j in joints}) if gripper_joint else None
    return ArmModel(base_link, tip_link, tuple(joints), pending, gripper, _boxes(links[base_link]))


def load_joint_limits(model: ArmModel, path: str | Path) -> ArmModel:
    """``model`` narrowed by MoveIt's joint_limits.yaml at ``path`` (:func:`with_joint_limits`); blocking."""
    try:
        document = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise RobotModelError(f"cannot read the joint limits {path}: {err}") from err
    limits = document.get("joint_limits") if isinstance(document, dict) else None
    return with_joint_limits(model, limits if isinstance(limits, dict) else {})


def with_joint_limits(model: ArmModel, limits: Mapping[str, Any]) -> ArmModel:
    """``model`` with MoveIt's per-joint limits (joint_limits.yaml's ``joint_limits`` mapping) applied to its chain:
    ``max_velocity`` where ``has_velocity_limits``, ``min_position``/``max_position`` where ``has_position_limits``.
    They only narrow the URDF's limits, never widen them: the URDF is what the hardware takes."""
    joints = []
    for joint in model.joints:
        entry = limits.get(joint.name) or {}
        lower, upper, velocity = joint.lower, joint.upper, joint.velocity
        try:
            if entry.get("has_velocity_limits") and entry.get("max_velocity") is not None:
                velocity = min(velocity, float(entry["max_velocity"]))
            if entry.get("has_position_limits"):
                lower = max(lower, float(entry.get("min_position", lower)))
                upper = min(upper, float(entry.get("max_position", upper)))
        except (TypeError, ValueError, AttributeError):
            raise RobotModelError(f"joint limits of {joint.name!r}: expected numbers, got {entry!r:.80}") from None
        if not (velocity > 0.0 and lower < upper):
            raise RobotModelError(f"joint limits of {joint.name!r} leave it no room to move")
        joints.append(replace(joint, lower=lower, upper=upper, velocity=velocity))
    return replace(model, joints=tuple(joints))


def _origin(joint: Any) -> Transform:
    origin = joint.origin if joint.origin is not None else np.eye(4)
    return np.asarray(origin, dtype=np.float64)


def _arm_joint(joint: Any, origin: Transform) -> ArmJoint:
    kind: JointKind = "prismatic" if joint.type == "prismatic" else "revolute"
    if joint.type not in ("revolute", "continuous", "prismatic"):
        raise RobotModelError(f"joint {joint.name!r} is {joint.type}: an arm's joints are revolute or prismatic")
    if joint.mimic is not None:
        raise RobotModelError(f"joint {joint.name!r} mimics {joint.mimic.joint!r}: the arm's chain moves on its own")
    lower, upper, velocity = _limits(joint)
    axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), dtype=np.float64)
    norm = float(np.linalg.norm(axis))
    if not norm > 0.0:
        raise RobotModelError(f"joint {joint.name!r} has a zero axis")
    return ArmJoint(joint.name, kind, joint.child, origin, axis / norm, lower, upper, velocity)


def _limits(joint: Any) -> tuple[float, float, float]:
    """(lower, upper, velocity); a continuous joint turns without bounds."""
    limit = joint.limit
    velocity = float(limit.velocity) if limit is not None and limit.velocity is not None else 0.0
    if not (math.isfinite(velocity) and velocity > 0.0):
        raise RobotModelError(f"joint {joint.name!r} has no positive velocity limit in its <limit>")
    if joint.type == "continuous":
        return -math.inf, math.inf, velocity
    lower = float(limit.lower) if limit.lower is not None else 0.0
    upper = float(limit.upper) if limit.upper is not None else 0.0
    if not lower < upper:
        raise RobotModelError(f"joint {joint.name!r}: its lower limit {lower:g} is not below its upper {upper:g}")
    return lower, upper, velocity


def _gripper(all_joints: Any, name: str, chain: set[str]) -> GripperJoint:
    joint = next((j for j in all_joints if j.name == name), None)
    if joint is None:
        raise RobotModelError(f"gripper_joint {name!r} is not a joint of the URDF")
    if name in chain:
        raise RobotModelError(f"gripper_joint {name!r} is on the arm's chain")
    if joint.type not in ("revolute", "prismatic"):
        raise RobotModelError(f"gripper_joint {name!r} is {joint.type}: expected revolute or prismatic")
    lower, upper, velocity = _limits(joint)
    mimics = tuple(
        (j.name, _or(j.mimic.multiplier, 1.0), _or(j.mimic.offset, 0.0))
        for j in all_joints
        if j.mimic is not None and j.mimic.joint == name
    )
    return GripperJoint(name, joint.type, lower, upper, velocity, mimics)


def _or(value: float | None, default: float) -> float:
    return default if value is None else float(value)


def _boxes(link: Any) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64]], ...]:
    """The link's collision boxes, each as the axis-aligned bounds of its eight corners in the link's frame."""
    boxes = []
    for collision in link.collisions:
        box = collision.geometry.box if collision.geometry is not None else None
        if box is None:
            continue
        half = np.asarray(box.size, dtype=np.float64) / 2.0
        origin = collision.origin if collision.origin is not None else np.eye(4)
        corners = np.array([[sx * half[0], sy * half[1], sz * half[2], 1.0]
                            for sx, sy, sz in itertools.product((-1, 1), repeat=3)])  # fmt: skip
        placed = (origin @ corners.T).T[:, :3]
        boxes.append((placed.min(axis=0), placed.max(axis=0)))
    return tuple(boxes)
