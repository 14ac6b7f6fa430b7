"""Differential-drive kinematics with velocity/acceleration limits and a bumper.

Map frame per REP 103 (x east, y north, metres, yaw in radians
counter-clockwise from +x). Velocities are body-frame ``linear`` (m/s, +
forward) and ``angular`` (rad/s, + counter-clockwise), as in
``geometry_msgs/Twist``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..fleet.occupancy import OccupancyGrid

__all__ = ["DiffDriveState", "DriveLimits", "normalize_angle", "step"]

_TWO_PI = 2.0 * math.pi


def normalize_angle(a: float) -> float:
    """Wrap ``a`` (radians) into ``(-pi, pi]``."""
    wrapped = math.remainder(a, _TWO_PI)  # in [-pi, pi]
    # remainder() maps odd multiples of pi to -pi; the contract excludes it.
    return math.pi if wrapped <= -math.pi else wrapped


@dataclass
class DiffDriveState:
    """Pose and the velocities actually achieved during the last step.

    ``yaw`` is kept in ``(-pi, pi]`` by :func:`step`.
    """

    x: float
    y: float
    yaw: float
    linear: float = 0.0
    angular: float = 0.0


@dataclass(frozen=True)
class DriveLimits:
    """Velocity and acceleration limits (all positive).

    Deceleration (speed magnitude decreasing towards the command or through
    zero) uses the separate, larger ``*_decel`` limits: real bases brake
    harder than they accelerate, and a released dead-man must stop the robot
    quickly. At the defaults a stop from 0.75 m/s or 1.8 rad/s takes at most
    0.3 s.
    """

    max_linear: float
    max_angular: float
    max_linear_accel: float = 1.0
    max_angular_accel: float = 3.0
    max_linear_decel: float = 2.5
    max_angular_decel: float = 6.0

    def __post_init__(self) -> None:
        for name in (
            "max_linear",
            "max_angular",
            "max_linear_accel",
            "max_angular_accel",
            "max_linear_decel",
            "max_angular_decel",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"DriveLimits.{name} must be positive and finite, got {value!r}")


def _ramp(current: float, target: float, accel: float, decel: float, dt: float) -> float:
    """Move ``current`` towards ``target`` within ``dt`` under accel/decel limits.

    Braking (|v| shrinking, including the part of a reversal down to zero)
    uses ``decel``; speeding up uses ``accel``. A reversal may brake to zero
    and start accelerating within the same step.
    """
    if current == target:
        return target
    braking = current != 0.0 and (current * target < 0.0 or abs(target) < abs(current))
    if not braking:
        delta = max(-accel * dt, min(accel * dt, target - current))
        return current + delta
    brake_to = target if current * target >= 0.0 else 0.0
    gap = abs(current - brake_to)
    if gap > decel * dt:
        return current - math.copysign(decel * dt, current)
    # Reached brake_to inside the step; spend what is left accelerating.
    remaining = dt - gap / decel
    if brake_to == target:
        return target
    return max(-accel * remaining, min(accel * remaining, target))


def _clamp_command(value: float, limit: float) -> float:
    # A NaN/inf command (bad client input) must never move the robot.
    if not math.isfinite(value):
        return 0.0
    return max(-limit, min(limit, value))


def step(
    state: DiffDriveState,
    cmd_linear: float,
    cmd_angular: float,
    dt: float,
    limits: DriveLimits,
    grid: OccupancyGrid | None = None,
    radius: float = 0.2,
) -> DiffDriveState:
    """Advance ``state`` by ``dt`` seconds and return a new state (input untouched).

    1. Commands are clamped to ``limits`` (non-finite commands become 0).
    2. Achieved velocities move towards the commands under the acceleration
       (speeding up) / deceleration (braking) limits.
    3. The pose is integrated exactly for constant velocities over ``dt``:
       a circular arc when ``angular != 0``, a straight line otherwise.
    4. Bumper: if ``grid`` is given and the new centre would be within
       ``radius`` of an occupied cell (or off the map), the translation is
       refused -- position kept, rotation applied, ``linear`` set to 0 -- so
       teleop cannot push a robot through a wall.

    Which grid to pass:
        * ``radius > 0`` (default): ``grid`` is the **plain** map. Only the
          cells within ``radius`` of the new centre are examined
          (:meth:`OccupancyGrid.clearance`), which is exactly the "inflated
          by radius" test without building or caching an inflated grid, and
          costs microseconds per call. A robot already closer than
          ``radius`` (spawned or placed touching a wall) may still translate
          as long as it does not get closer, so it can back away.
        * ``radius == 0``: ``grid`` is taken as **already inflated** by the
          footprint radius and the new centre's cell is looked up; a move
          ending in an occupied cell is refused (no back-away exception,
          since an inflated grid carries no distance information).

    ``dt`` must be finite and >= 0 (``ValueError`` otherwise).
    """
    if not (math.isfinite(dt) and dt >= 0.0):
        raise ValueError(f"dt must be finite and >= 0, got {dt!r}")
    v_cmd = _clamp_command(cmd_linear, limits.max_linear)
    w_cmd = _clamp_command(cmd_angular, limits.max_angular)
    v = _ramp(state.linear, v_cmd, limits.max_linear_accel, limits.max_linear_decel, dt)
    w = _ramp(state.angular, w_cmd, limits.max_angular_accel, limits.max_angular_decel, dt)

    dtheta = w * dt
    half = 0.5 * dtheta
    # Chord of the arc: 2 v/w sin(w dt / 2) along the mean heading. Written as
    # v dt * sinc(half) it is exact for arcs and degrades gracefully to the
    # straight line as w -> 0 (no v/w blow-up).
    sinc = math.sin(half) / half if abs(half) > 1e-9 else 1.0 - half * half / 6.0
    chord = v * dt * sinc
    heading = state.yaw + half
    x = state.x + chord * math.cos(heading)
    y = state.y + chord * math.sin(heading)
    yaw = normalize_angle(state.yaw + dtheta)

    if grid is not None and chord != 0.0 and _bumped(grid, radius, state.x, state.y, x, y):
        return DiffDriveState(state.x, state.y, yaw, 0.0, w)
    return DiffDriveState(x, y, yaw, v, w)


def _bumped(grid: OccupancyGrid, radius: float, x0: float, y0: float, x1: float, y1: float) -> bool:
    """Bumper decision for a move ``(x0, y0) -> (x1, y1)``; see :func:`step`."""
    if radius <= 0.0:
        return not grid.is_free(x1, y1)
    new_clearance = grid.clearance(x1, y1, radius)
    if new_clearance >= radius:
        return False
    return new_clearance < grid.clearance(x0, y0, radius)
