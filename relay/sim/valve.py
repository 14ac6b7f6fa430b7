"""The plumbing room's valve wheel (robots.yaml ``sim.valve``): a gripper that closes on its rim and turns it a quarter
turn shuts the leak it feeds, and the leak's reading falls back to the field's baseline.

Pure, no clock of its own: the sim backend calls :meth:`ValveWheel.step` at its physics rate with the gripper's tip
in the map frame, whether the gripper is closed, and the simulated time; :meth:`ValveWheel.shut` scales the leak's
sources in the sensor fields. The wheel turns with the tip about its axis while the gripper holds the rim: the tip's
angle about the axis, from where it closed on the rim, is the wheel's turn.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Final

import numpy as np
from numpy.typing import NDArray

from ..config import Valve
from ..fleet.events import ValveEvent
from .hazards import SensorField

#: A quarter turn (either way) shuts the valve.
QUARTER_TURN: Final = math.pi / 2
#: The tip closes on the rim when it is this near it (m), in the wheel's plane and across it: a finger's width.
GRASP: Final = 0.03
#: Sources of the valve's hazard within this distance of it (m, on the floor) are the leak it feeds.
REACH: Final = 2.0
#: The wheel's turn is reported again once it has moved this much (rad): half a degree, finer than the eye sees.
REPORT_STEP: Final = math.radians(0.5)

Vec3 = tuple[float, float, float]


class ValveWheel:
    def __init__(self, valve: Valve) -> None:
        self.valve = valve
        self.turned = 0.0  # rad, the wheel's turn so far (either sign)
        self.shut_at: float | None = None  # simulated time it was shut
        self._held: float | None = None  # the tip's angle about the axis at the last step, while it holds the rim
        self._gripping = False  # the gripper was closed at the last step
        self._reported: ValveEvent | None = None  # the last state reported

    @property
    def held(self) -> bool:
        return self._held is not None

    def step(self, tip: Vec3 | None, gripping: bool, now: float) -> bool:
        """The gripper's tip (map frame; None: no arm) and whether it is closed, at simulated time ``now``: whether
        the wheel was shut in this step. A gripper that closes with its tip at the rim takes the wheel (one closed
        elsewhere that comes to the rim does not); opening it, or slipping off the rim, lets go."""
        closing = gripping and not self._gripping
        self._gripping = gripping
        if self.shut_at is not None or tip is None or not gripping:
            self._held = None
            return False
        angle, off_rim, across = self._where(tip)
        near = off_rim <= GRASP and across <= GRASP
        if closing and near:
            self._held = angle
            return False
        if self._held is None or not near:
            self._held = None
            return False
        self.turned += math.remainder(angle - self._held, math.tau)
        self._held = angle
        if abs(self.turned) >= QUARTER_TURN:
            self.shut_at = now
            self._held = None
            return True
        return False

    def report(self) -> ValveEvent | None:
        """The wheel's state when it differs from the last one reported (held, shut, or turned by REPORT_STEP), else
        None: the first call always reports."""
        v, last = self.valve, self._reported
        shut = self.shut_at is not None
        if (
            last is not None
            and last.held == self.held
            and last.shut == shut
            and abs(last.angle - self.turned) < REPORT_STEP
        ):
            return None
        self._reported = ValveEvent(v.x, v.y, v.z, v.yaw, v.radius, self.turned, self.held, shut)
        return self._reported

    def _where(self, tip: Vec3) -> tuple[float, float, float]:
        """The tip's angle about the wheel's axis, and its distances from the rim (in the plane) and the plane."""
        v = self.valve
        ax, ay = math.cos(v.yaw), math.sin(v.yaw)  # the axis, horizontal
        dx, dy, dz = tip[0] - v.x, tip[1] - v.y, tip[2] - v.z
        across = abs(dx * ax + dy * ay)
        side = -dx * ay + dy * ax  # in the wheel's plane: horizontal, then up
        return math.atan2(dz, side), abs(math.hypot(side, dz) - v.radius), across

    def shut(self, fields: Mapping[str, SensorField], now: float) -> Mapping[str, SensorField]:
        """``fields`` with the leak's sources faded as long as the valve has been shut at ``now`` (simulated s)."""
        if self.shut_at is None:
            return fields
        v = self.valve
        field = fields.get(v.hazard)
        if field is None:
            return fields
        left = math.exp(-max(0.0, now - self.shut_at) / v.fade)
        sources = tuple(
            replace(s, peak=s.peak * left) if math.hypot(s.x - v.x, s.y - v.y) <= REACH else s for s in field.sources
        )
        return {**fields, v.hazard: replace(field, sources=sources)}


def tip_in_map(pose: tuple[float, float, float], tip: Sequence[float] | NDArray[np.float64]) -> Vec3:
    """An arm's tip (its base link frame) in the map frame, the arm's base link taken at the robot's pose on the
    floor (TurtleBot3's base_link is 1 cm above its base_footprint: within the grasp)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    tx, ty, tz = (float(v) for v in tip[:3])
    return x + c * tx - s * ty, y + s * tx + c * ty, tz
