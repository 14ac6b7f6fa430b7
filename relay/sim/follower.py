"""Path following for simulated differential-drive robots (pure pursuit).

Map frame per REP 103. The follower is a small state machine::

    drive --(within position tolerance of the goal)--> turn --(yaw ok)--> done
                      (no final yaw: straight to done)

While driving it rotates in place when the heading error to the lookahead
point exceeds ``rotate_threshold`` and resumes pure pursuit only once the
error is below ``resume_threshold``; the gap between the two (hysteresis)
and the latched phases are what keep it from oscillating. It also starts in
that rotate-in-place state, so it aligns with the path before moving. When
the kinematics' bumper refuses a forward step (achieved linear speed 0 and
the pose unchanged after a forward command) it turns back to the nearest
point of the path and creeps there before resuming. It drives forward only.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from enum import Enum

from .kinematics import DiffDriveState, DriveLimits, normalize_angle

__all__ = ["PathFollower"]

Point = tuple[float, float]


# Back on the path (within this many metres of it) ends a bump recovery.
_RECOVERED = 0.05
# Creep speed (m/s) while returning to the path after a bump.
_RECOVERY_SPEED = 0.15


class _Phase(Enum):
    DRIVE = "drive"
    TURN = "turn"
    DONE = "done"


class PathFollower:
    """Follows one path to its last waypoint, then optionally turns to ``final_yaw``.

    Contract:
        * ``path`` has at least one finite waypoint (metres); the goal is the
          last one. The robot need not start on the path.
        * :meth:`command` is called once per control tick with the current
          state; it returns ``(linear, angular, done)`` within ``limits``.
          Once ``done`` is True it stays True and commands are zero.
        * Position is accepted within ``position_tolerance`` of the goal
          (default 0.1 m; the robot then brakes within a few millimetres),
          yaw within ``yaw_tolerance`` (default 0.05 rad).
        * The follower is stateful (progress along the path, phase); use a
          new instance for a new goal.
    """

    def __init__(
        self,
        path: Sequence[Point],
        final_yaw: float | None = None,
        *,
        position_tolerance: float = 0.1,
        yaw_tolerance: float = 0.05,
        lookahead: float = 0.5,
        rotate_threshold: float = math.radians(60.0),
        resume_threshold: float = math.radians(25.0),
        slowdown_distance: float = 0.6,
        min_linear: float = 0.05,
        min_angular: float = 0.15,
        heading_gain: float = 2.0,
    ) -> None:
        """Validate parameters and precompute the path's arc lengths (``ValueError`` on bad input)."""
        if len(path) == 0:
            raise ValueError("path must contain at least one waypoint")
        pts = [(float(p[0]), float(p[1])) for p in path]
        if not all(math.isfinite(v) for p in pts for v in p):
            raise ValueError("path waypoints must be finite")
        if final_yaw is not None and not math.isfinite(final_yaw):
            raise ValueError(f"final_yaw must be finite, got {final_yaw!r}")
        positives = {
            "position_tolerance": position_tolerance,
            "yaw_tolerance": yaw_tolerance,
            "lookahead": lookahead,
            "slowdown_distance": slowdown_distance,
            "min_linear": min_linear,
            "min_angular": min_angular,
            "heading_gain": heading_gain,
        }
        for name, value in positives.items():
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be positive, got {value!r}")
        if not 0.0 < resume_threshold < rotate_threshold <= math.pi:
            raise ValueError("need 0 < resume_threshold < rotate_threshold <= pi")
        self._pts = pts
        self._final_yaw = None if final_yaw is None else normalize_angle(final_yaw)
        self._pos_tol = position_tolerance
        self._yaw_tol = yaw_tolerance
        self._lookahead = lookahead
        self._rotate_threshold = rotate_threshold
        self._resume_threshold = resume_threshold
        self._slowdown = slowdown_distance
        self._min_linear = min_linear
        self._min_angular = min_angular
        self._gain = heading_gain
        cumulative = [0.0]
        for (ax, ay), (bx, by) in itertools.pairwise(pts):
            cumulative.append(cumulative[-1] + math.hypot(bx - ax, by - ay))
        self._cum = cumulative
        self._seg = 0  # index of the segment the robot was last projected onto
        self._progress = 0.0  # arc length reached; never decreases
        self._phase = _Phase.DRIVE
        # Start in the rotate-in-place state: from standstill the robot first
        # turns to within resume_threshold of the carrot, because a
        # pure-pursuit arc started up to rotate_threshold off course bulges
        # up to ~0.15 m sideways -- more than the planner's margin over the
        # bumper radius.
        self._rotating = True
        self._recovering = False  # returning to the path after a bump
        self._last_linear = 0.0
        self._last_pose = (math.nan, math.nan)

    @property
    def path(self) -> list[Point]:
        """A copy of the waypoints being followed."""
        return list(self._pts)

    @property
    def goal(self) -> Point:
        """The last waypoint."""
        return self._pts[-1]

    @property
    def final_yaw(self) -> float | None:
        """Requested final heading in ``(-pi, pi]``, or None."""
        return self._final_yaw

    @property
    def done(self) -> bool:
        """True once the goal (and final yaw, if any) has been reached."""
        return self._phase is _Phase.DONE

    def command(self, state: DiffDriveState, limits: DriveLimits) -> tuple[float, float, bool]:
        """Return ``(linear, angular, done)`` for the current ``state``."""
        if self._phase is _Phase.DRIVE:
            gx, gy = self._pts[-1]
            if math.hypot(gx - state.x, gy - state.y) <= self._pos_tol:
                # Latched: small drift while braking or turning must not
                # restart driving (that is how followers end up dithering).
                self._phase = _Phase.DONE if self._final_yaw is None else _Phase.TURN
            else:
                linear, angular = self._drive(state, limits)
                return linear, angular, False
        if self._phase is _Phase.TURN:
            assert self._final_yaw is not None
            error = normalize_angle(self._final_yaw - state.yaw)
            if abs(error) <= self._yaw_tol:
                self._phase = _Phase.DONE
            else:
                return 0.0, self._turn_rate(error, limits), False
        return 0.0, 0.0, True

    # -- internals ---------------------------------------------------------

    def _turn_rate(self, error: float, limits: DriveLimits) -> float:
        """Angular speed towards ``error`` that can stop at zero error without overshoot."""
        magnitude = min(
            self._gain * abs(error),
            # Brakeable from here at the (conservative) acceleration limit.
            math.sqrt(2.0 * limits.max_angular_accel * abs(error)),
            limits.max_angular,
        )
        # Floor so the last few hundredths of a radian do not take forever.
        magnitude = max(magnitude, min(self._min_angular, limits.max_angular))
        return math.copysign(magnitude, error)

    def _advance(self, x: float, y: float) -> None:
        """Move the progress marker to the closest point on the path ahead.

        Only segments starting within one lookahead of the current progress
        are searched, so a path that doubles back near itself cannot make
        the robot skip ahead.
        """
        pts = self._pts
        if len(pts) < 2:
            return
        best_d2 = math.inf
        best_seg = self._seg
        best_s = self._progress
        horizon = self._progress + self._lookahead
        for i in range(self._seg, len(pts) - 1):
            if self._cum[i] > horizon:
                break
            (ax, ay), (bx, by) = pts[i], pts[i + 1]
            dx, dy = bx - ax, by - ay
            seg_len2 = dx * dx + dy * dy
            t = 0.0 if seg_len2 == 0.0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / seg_len2))
            px, py = ax + t * dx, ay + t * dy
            d2 = (x - px) ** 2 + (y - py) ** 2
            if d2 < best_d2:
                best_d2 = d2
                best_seg = i
                best_s = self._cum[i] + t * math.sqrt(seg_len2)
        if best_s >= self._progress:
            self._seg = best_seg
            self._progress = best_s

    def _point_at(self, s: float) -> Point:
        """Point at arc length ``s`` along the path (clamped to the ends)."""
        pts, cum = self._pts, self._cum
        if s >= cum[-1]:
            return pts[-1]
        i = self._seg
        while i + 1 < len(cum) - 1 and cum[i + 1] <= s:
            i += 1
        seg_len = cum[i + 1] - cum[i]
        t = 0.0 if seg_len == 0.0 else (s - cum[i]) / seg_len
        (ax, ay), (bx, by) = pts[i], pts[i + 1]
        return ax + t * (bx - ax), ay + t * (by - ay)

    def _drive(self, state: DiffDriveState, limits: DriveLimits) -> tuple[float, float]:
        linear, angular = self._pursue(state, limits)
        self._last_linear = linear
        self._last_pose = (state.x, state.y)
        return linear, angular

    def _pursue(self, state: DiffDriveState, limits: DriveLimits) -> tuple[float, float]:
        self._advance(state.x, state.y)
        if self._last_linear > 0.0 and state.linear == 0.0 and (state.x, state.y) == self._last_pose:
            # The bumper refused our last forward step: the pursuit arc (or
            # the straight line to the carrot) grazes an obstacle. Pushing on
            # would deadlock, so head back to the path itself -- it was
            # planned with more clearance than the bumper radius.
            self._recovering = True
            self._rotating = True
        gx, gy = self._pts[-1]
        to_goal = math.hypot(gx - state.x, gy - state.y)
        if to_goal <= self._lookahead:
            # Near the end aim at the goal itself, so the carrot cannot sit
            # beside the robot and make it circle.
            tx, ty = gx, gy
        else:
            tx, ty = self._point_at(self._progress + self._lookahead)
        if self._recovering:
            px, py = self._point_at(self._progress)
            if math.hypot(px - state.x, py - state.y) > _RECOVERED:
                tx, ty = px, py
            else:
                self._recovering = False
        dx, dy = tx - state.x, ty - state.y
        distance = math.hypot(dx, dy)
        alpha = normalize_angle(math.atan2(dy, dx) - state.yaw) if distance > 1e-9 else 0.0

        if self._rotating:
            self._rotating = abs(alpha) > self._resume_threshold
        else:
            self._rotating = abs(alpha) > self._rotate_threshold
        if self._rotating:
            return 0.0, self._turn_rate(alpha, limits)

        remaining = max(self._cum[-1] - self._progress, to_goal)
        speed = min(
            limits.max_linear,
            # Linear slow-down zone, then a braking-distance cap so the
            # acceleration limit can actually stop the robot at the goal.
            max(self._min_linear, limits.max_linear * remaining / self._slowdown),
            math.sqrt(2.0 * limits.max_linear_accel * remaining),
        )
        if self._recovering:
            speed = min(speed, _RECOVERY_SPEED)
        # Less speed while still misaligned: tighter arcs, less corner cutting.
        speed *= max(math.cos(alpha), 0.2)
        curvature = 2.0 * math.sin(alpha) / max(distance, 1e-9)
        angular = speed * curvature
        if abs(angular) > limits.max_angular:
            # Keep the pure-pursuit arc (same curvature), just slower.
            angular = math.copysign(limits.max_angular, angular)
            speed = limits.max_angular / abs(curvature)
        return speed, angular
