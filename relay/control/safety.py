"""Safety rules that do not depend on I/O: velocity clamps, goal checks and the teleop deadman.

The command rules (``relay.session.commands``, ``relay.control.control``) apply them to every command before a backend
sees it; each rule has tests in tests/test_safety.py and end to end through /ws in tests/test_relay_ws.py.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Final

from ..config import Limits
from ..errors import CommandRejected
from ..fleet.occupancy import OccupancyGrid
from ..session.protocol import ErrorCode, robot_identifier


@dataclass(frozen=True, slots=True)
class Clamped:
    linear: float
    angular: float
    clamped: bool  # True when either value was reduced to the robot's limits


def clamp_velocity(linear: float, angular: float, limits: Limits) -> Clamped:
    """Velocities limited to ``[-limit, +limit]`` of the robot (inputs are already finite)."""
    lin = max(-limits.linear, min(limits.linear, linear))
    ang = max(-limits.angular, min(limits.angular, angular))
    return Clamped(lin, ang, lin != linear or ang != angular)


def check_goal(robot: str, x: float, y: float, grid: OccupancyGrid | None) -> None:
    """Reject a goal outside the known map. Finiteness is already guaranteed by the protocol parser."""
    identifier = robot_identifier(robot, "goal_pose")
    if not (math.isfinite(x) and math.isfinite(y)):
        raise CommandRejected(ErrorCode.BAD_REQUEST, f"{identifier}: x and y must be finite")
    if grid is None:
        return
    min_x, min_y, max_x, max_y = grid.bounds
    if not (min_x <= x <= max_x and min_y <= y <= max_y):
        raise CommandRejected(
            ErrorCode.OUT_OF_BOUNDS,
            f"{identifier}: ({x:.2f}, {y:.2f}) is outside the map, which spans "
            f"x {min_x:.2f}..{max_x:.2f} and y {min_y:.2f}..{max_y:.2f}",
        )


#: A goal closer than this to another robot (metres, centre to centre) is refused with ``occupied``: two robots'
#: footprints (a TurtleBot3 Waffle is 0.28 x 0.31 m) and a margin for the one already there to be measured wrong. The
#: web client shows the same rule on its pointer before the press (generated into xr_client/src/protocol.js).
GOAL_CLEARANCE: Final = 0.6


def check_goal_clear(robot: str, x: float, y: float, others: Mapping[str, tuple[float, float]]) -> None:
    """Reject a goal on or next to another robot (``others``: where the robots other than ``robot`` stand)."""
    for name, (ox, oy) in sorted(others.items()):
        distance = math.hypot(ox - x, oy - y)
        if name != robot and distance < GOAL_CLEARANCE:
            raise CommandRejected(
                ErrorCode.OCCUPIED,
                f"{robot_identifier(robot, 'goal_pose')}: ({x:.2f}, {y:.2f}) is {distance:.2f} m from {name}; "
                f"a goal keeps {GOAL_CLEARANCE} m from other robots",
            )


class Deadman:
    """Tracks which client teleoperates which robot and when it last commanded it.

    Time is passed in (the loop's monotonic clock), so the rules are testable without sleeping. A robot whose
    operator has not sent ``cmd_vel`` for ``timeout`` seconds, or whose operator disconnected, must get a zero
    velocity command: the caller does that with what ``expired`` and ``release_client`` return.
    """

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self._active: dict[str, tuple[str, float]] = {}  # robot -> (client id, last command time)

    def feed(self, robot: str, client_id: str, now: float) -> str | None:
        """Record a cmd_vel; returns the previous operator's id when control changed hands."""
        previous = self._active.get(robot)
        self._active[robot] = (client_id, now)
        if previous is not None and previous[0] != client_id:
            return previous[0]
        return None

    def controller(self, robot: str) -> str | None:
        entry = self._active.get(robot)
        return entry[0] if entry else None

    def expired(self, now: float) -> list[str]:
        """Robots whose operator fell silent; they are released and must be stopped."""
        stale = [robot for robot, (_, last) in self._active.items() if now - last >= self.timeout]
        for robot in stale:
            del self._active[robot]
        return stale

    def release_client(self, client_id: str) -> list[str]:
        """Robots the client was driving (on disconnect); they are released and must be stopped."""
        robots = [robot for robot, (cid, _) in self._active.items() if cid == client_id]
        for robot in robots:
            del self._active[robot]
        return robots

    def release_robot(self, robot: str) -> None:
        self._active.pop(robot, None)

    def next_deadline(self) -> float | None:
        """The earliest time at which ``expired`` can return something."""
        if not self._active:
            return None
        return min(last for _, last in self._active.values()) + self.timeout


def reset_refusal(
    rule: str, pressers: Mapping[str, str], latched: Iterable[str], robot: str | None, who: str, admin: bool
) -> str | None:
    """Why ``who`` may not reset the estop of ``robot`` (or of every ``latched`` robot) under robots.yaml's
    ``safety.estop_reset`` ``rule``, or None. ``presser``: only who pressed it (``pressers``: robot -> account or
    client id) and admins may; ``anyone``: whoever's role may (relay/accounts/roles.py, checked before)."""
    if rule != "presser" or admin:
        return None
    latched = set(latched)
    robots = [robot] if robot is not None else list(latched)
    others = sorted({pressers[r] for r in robots if r in latched and r in pressers} - {who})
    if not others:
        return None
    return (
        f"pressed by {', '.join(others)}: only they or an admin may reset it (robots.yaml: safety.estop_reset: presser)"
    )
