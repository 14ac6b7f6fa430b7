"""An arm on the wire (docs/protocol.md, "Arms"): the operator's ``<robot>/arm/twist``, ``<robot>/arm/pose`` and
``<robot>/arm/gripper``, and the relay's ``<robot>/joints``.

Declared like every command (relay/wire/declare.py) and gathered in relay/session/protocol.py; the rules a command
then passes (the motion gate, the arm's clamps and refusals, the deadman) are relay/control/arm_control.py's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Final, Literal, TypedDict

import numpy as np

from ..errors import ProtocolError
from ..wire.declare import Forms, Frame, WireCommand, choice, command, custom, from_identifier, real, request, text
from ..wire.fields import ErrorCode, RequestId, show
from ..wire.identifiers import robot_identifier

#: The frames a twist may be given in: the arm's base link (MoveIt Servo's ``planning_frame``) or the tip's own.
TWIST_FRAMES: Final = ("base", "tip")
#: A component of a twist beyond this is a mistake, not a speed (the relay clamps far below it anyway).
MAX_TWIST: Final = 100.0
#: A named pose's name: a word, as SRDF group states are named.
POSE_NAME_LENGTH: Final = 64
Vec3 = tuple[float, float, float]


def _vector(value: Any, field: str, identifier: str) -> Vec3:
    if value is None:
        raise ProtocolError(ErrorCode.BAD_REQUEST, f"{identifier}: missing field '{field}'")
    if (
        not isinstance(value, list)
        or len(value) != 3
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        or not all(math.isfinite(v) and abs(v) <= MAX_TWIST for v in value)
    ):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field '{field}' must be [x, y, z], three finite numbers within ±{MAX_TWIST:g}, "
            f"got {show(value)}",
        )
    return float(value[0]), float(value[1]), float(value[2])


@command("<robot>/arm/twist")
@dataclass(frozen=True, slots=True)
class ArmTwist(WireCommand):
    """The tip's velocity (m/s, rad/s) in ``frame``, followed until the next one; zeros stop the arm."""

    robot: str = from_identifier()
    linear: Vec3 = custom(_vector, "[number, number, number]", required=True)
    angular: Vec3 = custom(_vector, "[number, number, number]", required=True)
    id: RequestId | None = request(required=False)
    frame: Literal["base", "tip"] = choice(TWIST_FRAMES, default="base")

    @property
    def moves(self) -> bool:
        return any(self.linear) or any(self.angular)


@command("<robot>/arm/pose")
@dataclass(frozen=True, slots=True)
class ArmPose(WireCommand):
    """Move the arm to a named pose of its SRDF (``home``), at a bounded joint speed."""

    robot: str = from_identifier()
    id: RequestId = request()
    name: str = text()


@command("<robot>/arm/gripper")
@dataclass(frozen=True, slots=True)
class ArmGripper(WireCommand):
    """The gripper to a named ``state`` of its SRDF (``open``, ``close``) or to a ``position`` (m or rad of its
    joint, within its limits)."""

    FORMS: ClassVar[Forms] = {
        "ArmGripperStateCommand": (("",), ("state",), ()),
        "ArmGripperPositionCommand": (("",), ("position",), ()),
    }
    robot: str = from_identifier()
    id: RequestId = request()
    state: str | None = text(required=False)
    position: float | None = real(required=False, low=-MAX_TWIST, high=MAX_TWIST)

    def check(self, frame: Frame) -> None:
        if (self.state is None) == (self.position is None):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: give exactly one of state, position")


ARM_COMMANDS: Final = (ArmTwist, ArmPose, ArmGripper)
ArmCommand = ArmTwist | ArmPose | ArmGripper


class JointsMessage(TypedDict):
    identifier: str
    stamp: float
    names: list[str]
    positions: list[float]
    #: The arm's skeleton at these positions: the base link's origin, each joint's, then the tip (metres, in the
    #: arm's base link frame), so that a client draws the arm without its URDF.
    points: list[list[float]]
    #: The gripper joint's open and closed positions (the SRDF's states, else its limits), [] without a gripper: a
    #: client maps a trigger's travel onto them (``<robot>/arm/gripper``'s ``position``).
    gripper: list[float]


def joints_message(
    robot: str,
    *,
    stamp: float,
    names: Sequence[str],
    positions: Sequence[float],
    points: Any,
    gripper: tuple[float, float] | None = None,
) -> JointsMessage:
    # Positions to 1e-4 rad (0.006 degrees) and points to 0.1 mm: far finer than the 1 degree the twin must match.
    return {
        "identifier": robot_identifier(robot, "joints"),
        "stamp": round(stamp, 6),
        "names": list(names),
        "positions": np.round(np.asarray(positions, dtype=np.float64), 4).tolist(),
        "points": np.round(np.asarray(points, dtype=np.float64), 4).tolist(),
        "gripper": [] if gripper is None else [round(gripper[0], 5), round(gripper[1], 5)],
    }
