"""A Nav2-shaped navigator for one simulated robot, without I/O: what ``tools/fake_fleet.py --nav2`` runs per robot.

Seen from outside it behaves as Nav2's bt_navigator, planner_server and controller_server do (Jazzy):

- a goal on ``goal_pose`` becomes a NavigateToPose goal with a fresh UUID (bt_navigator sends it to its own action):
  ACCEPTED, then EXECUTING on the next controller tick; a goal that arrives while another runs preempts it, which
  Nav2's SimpleActionServer reports as ABORTED with an empty result;
- it is planned on the sim's grid around the walls and the other robots (``relay.sim.world.SimWorld.plan``); a goal
  that cannot be planned is ABORTED with ComputePathToPose's error code, which bt_navigator puts in NavigateToPose's
  result: GOAL_OUTSIDE_MAP (204), GOAL_OCCUPIED (206), START_OUTSIDE_MAP (203) or NO_VALID_PATH (208). Nav2 would
  first run its recoveries (clear the costmaps, spin, wait, back up; tens of seconds): the fake aborts at once;
- the controller follows the path (``relay.sim.follower``) and its velocity is published at 20 Hz while the goal
  executes; it never moves the robot itself: the velocity goes to the watchdog on ``cmd_vel_nav``, and the base
  moves only from ``cmd_vel``;
- the goal SUCCEEDED when the robot is there (the controller sends one zero, as controller_server does); it is
  ABORTED with FollowPath's FAILED_TO_MAKE_PROGRESS (105) when the robot has not moved 0.5 m in 10 s (Nav2's
  SimpleProgressChecker defaults): a robot the gate holds does not navigate forever;
- cancel follows rcl_action's rules (``cancel``); a cancelled goal is CANCELING, then CANCELED on the next tick, and
  the controller sends one zero, unless it ``misbehaves``: then it keeps publishing the cancelled goal's velocity,
  which is what the watchdog's gate must hold against;
- feedback, each tick while EXECUTING, is bt_navigator's: the pose, the time since the goal started, the distance
  left along the path from the robot's closest point, the time left at the current speed (0 below 1 cm/s or
  10 cm), and the recoveries run (none: the fake runs none).

Goals are kept for the status list until ``RESULT_TIMEOUT`` after they end (rcl_action's default) and at most
``MAX_GOALS`` of them. Pure: times are passed in (seconds on the wall clock, which stamps the goals), and the robot's
state too. Tested in tests/test_navigator.py.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

from .follower import PathFollower
from .kinematics import DiffDriveState, DriveLimits
from .world import PLANNING_RADIUS, ROBOT_RADIUS, NoPathError, SimWorld

# action_msgs/msg/GoalStatus
UNKNOWN, ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = range(7)
ACTIVE = (ACCEPTED, EXECUTING, CANCELING)
# action_msgs/srv/CancelGoal's return codes
ERROR_NONE, ERROR_REJECTED, ERROR_UNKNOWN_GOAL_ID, ERROR_GOAL_TERMINATED = range(4)
# nav2_msgs (Jazzy): ComputePathToPose's and FollowPath's error codes, as NavigateToPose's result carries them.
START_OUTSIDE_MAP, GOAL_OUTSIDE_MAP, GOAL_OCCUPIED, NO_VALID_PATH = 203, 204, 206, 208
FAILED_TO_MAKE_PROGRESS = 105

#: Seconds between controller ticks: Nav2's controller_frequency default, 20 Hz.
PERIOD = 0.05
#: Nav2's SimpleProgressChecker: the robot must move this far (m) within this long (s).
PROGRESS_RADIUS, PROGRESS_TIME = 0.5, 10.0
#: rcl_action keeps an ended goal (and its result) this long (s): 15 minutes.
RESULT_TIMEOUT = 900.0
#: At most this many goals in the status list; the oldest ended ones go first.
MAX_GOALS = 16

Point = tuple[float, float]


class PlanError(Exception):
    """A goal the planner refuses: Nav2's error code and why."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


@dataclass
class NavGoal:
    uuid: bytes  # 16 bytes, unique_identifier_msgs/UUID
    stamp: int  # when it was accepted (GoalInfo.stamp), ns
    x: float
    y: float
    yaw: float | None
    status: int = ACCEPTED
    error_code: int = 0
    error_msg: str = ""
    ended: float | None = None


@dataclass(frozen=True, slots=True)
class Feedback:
    uuid: bytes
    x: float
    y: float
    yaw: float
    navigation_time: float
    estimated_time_remaining: float
    number_of_recoveries: int
    distance_remaining: float


@dataclass(frozen=True, slots=True)
class Tick:
    command: tuple[float, float] | None  # the controller's velocity now; None: it publishes nothing
    feedback: Feedback | None
    status_changed: bool


class Navigator:
    """One robot's navigation: its goals and their statuses, and its controller. ``goal`` and ``cancel`` change
    statuses (the caller publishes them then); ``step`` tells when it changed them."""

    def __init__(
        self, plan: Callable[[float, float], list[Point]], limits: DriveLimits, *, misbehave_after_cancel: bool = False
    ) -> None:
        """``plan(x, y)`` returns a path from the robot or raises PlanError."""
        self._plan = plan
        self._limits = limits
        self.misbehave_after_cancel = misbehave_after_cancel
        self.goals: list[NavGoal] = []
        self._current: NavGoal | None = None  # the goal the controller works on
        self._follower: PathFollower | None = None
        self._started = 0.0
        self._anchor: tuple[float, float, float] = (0.0, 0.0, 0.0)  # progress checker: x, y, since
        self._rogue: PathFollower | None = None  # a cancelled goal's path the misbehaving controller still follows
        self._zero_due = False  # one zero from the controller when a goal ends
        self._changed = False

    # -- the action's side ------------------------------------------------------------------------

    def goal(self, uuid: bytes, x: float, y: float, yaw: float | None, now: float) -> NavGoal:
        """A goal from goal_pose: accepted, to execute on the next tick; the one running is preempted."""
        if self._current is not None and self._current.status in ACTIVE:
            self._end(self._current, ABORTED, now)  # SimpleActionServer's preemption: abort with an empty result
            self._zero_due = False  # the controller goes straight on to the new goal
        goal = NavGoal(uuid, stamp_ns(now), x, y, yaw)
        self.goals.append(goal)
        self._current, self._follower, self._rogue = goal, None, None
        return goal

    def cancel(self, uuid: bytes, stamp: int, now: float) -> tuple[int, list[NavGoal]]:
        """CancelGoal as rcl_action answers it: (return code, the goals now canceling); ``stamp`` in ns.

        A zero UUID and a zero stamp cancel every active goal; a UUID alone that goal (ERROR_UNKNOWN_GOAL_ID if
        there is none, ERROR_GOAL_TERMINATED if it ended); a stamp every goal accepted at or before it, and the
        UUID's goal with it."""
        zero_id = uuid == bytes(16)
        if not zero_id and stamp == 0:
            goal = next((g for g in self.goals if g.uuid == uuid), None)
            if goal is None:
                return ERROR_UNKNOWN_GOAL_ID, []
            if goal.status not in (ACCEPTED, EXECUTING):
                return ERROR_GOAL_TERMINATED, []
            chosen = [goal]
        else:
            every = zero_id and stamp == 0
            chosen = [
                g for g in self.goals
                if g.status in (ACCEPTED, EXECUTING) and (every or g.stamp <= stamp or g.uuid == uuid)
            ]  # fmt: skip
        for goal in chosen:
            goal.status = CANCELING
        return ERROR_NONE, chosen

    def result(self, uuid: bytes) -> NavGoal | None:
        return next((g for g in self.goals if g.uuid == uuid), None)

    # -- the controller ---------------------------------------------------------------------------

    def step(self, state: DiffDriveState, now: float) -> Tick:
        """One controller tick (every PERIOD) with the robot's state now."""
        feedback = None
        goal = self._current
        if goal is not None and goal.status == CANCELING:
            rogue = self._follower if self.misbehave_after_cancel else None
            self._end(goal, CANCELED, now)
            if rogue is not None:
                self._rogue, self._zero_due = rogue, False
        elif goal is not None and goal.status == ACCEPTED:
            goal.status, self._started, self._changed = EXECUTING, now, True
        elif goal is not None and goal.status == EXECUTING:
            if self._follower is None:
                self._start(goal, state, now)
            if self._follower is not None:
                feedback = self._drive(goal, self._follower, state, now)
        for other in self.goals:
            if other is not goal and other.status == CANCELING:
                self._end(other, CANCELED, now)
        self._expire(now)
        command = self._command(state, goal, feedback, now)
        changed, self._changed = self._changed, False
        return Tick(command, feedback, changed)

    def _start(self, goal: NavGoal, state: DiffDriveState, now: float) -> None:
        try:
            path = self._plan(goal.x, goal.y)
        except PlanError as exc:
            self._end(goal, ABORTED, now, exc.code, str(exc))
            return
        self._follower = PathFollower(path, final_yaw=goal.yaw)
        self._anchor = (state.x, state.y, now)

    def _drive(self, goal: NavGoal, follower: PathFollower, state: DiffDriveState, now: float) -> Feedback | None:
        x0, y0, since = self._anchor
        if math.hypot(state.x - x0, state.y - y0) >= PROGRESS_RADIUS:
            self._anchor = (state.x, state.y, now)
        elif now - since > PROGRESS_TIME:
            message = f"the robot moved less than {PROGRESS_RADIUS:g} m in {PROGRESS_TIME:g} s"
            self._end(goal, ABORTED, now, FAILED_TO_MAKE_PROGRESS, message)
            return None
        remaining = _remaining(follower.path, state.x, state.y)
        speed = abs(state.linear)
        eta = remaining / speed if speed > 0.01 and remaining > 0.1 else 0.0
        return Feedback(goal.uuid, state.x, state.y, state.yaw, now - self._started, eta, 0, remaining)

    def _command(
        self, state: DiffDriveState, goal: NavGoal | None, feedback: Feedback | None, now: float
    ) -> tuple[float, float] | None:
        if self._rogue is not None:
            linear, angular, done = self._rogue.command(state, self._limits)
            if done:
                self._rogue = None
            return linear, angular
        if feedback is not None and goal is not None and self._follower is not None:
            linear, angular, done = self._follower.command(state, self._limits)
            if not done:
                return linear, angular
            self._end(goal, SUCCEEDED, now)
        if self._zero_due:
            self._zero_due = False
            return 0.0, 0.0
        return None

    def _end(self, goal: NavGoal, status: int, now: float, code: int = 0, message: str = "") -> None:
        goal.status, goal.error_code, goal.error_msg, goal.ended = status, code, message, now
        self._changed = True
        if goal is self._current:
            self._zero_due = self._follower is not None  # controller_server publishes a zero when it stops
            self._follower = None

    def _expire(self, now: float) -> None:
        kept = [g for g in self.goals if g.ended is None or now - g.ended <= RESULT_TIMEOUT]
        ended = [g for g in kept if g.ended is not None]
        while len(kept) > MAX_GOALS and ended:
            kept.remove(ended.pop(0))
        if len(kept) != len(self.goals):
            self.goals = kept
            self._changed = True


def stamp_ns(seconds: float) -> int:
    """A time as GoalInfo carries it (rcl_action compares stamps in integer nanoseconds)."""
    return round(seconds * 1e9)


def _remaining(path: list[Point], x: float, y: float) -> float:
    """The length of ``path`` from the point closest to (x, y) to its end (bt_navigator's distance_remaining)."""
    if len(path) < 2:
        return math.hypot(path[-1][0] - x, path[-1][1] - y) if path else 0.0
    best, best_index, best_point = math.inf, 0, path[0]
    for i, ((ax, ay), (bx, by)) in enumerate(itertools.pairwise(path)):
        dx, dy = bx - ax, by - ay
        length2 = dx * dx + dy * dy
        t = 0.0 if length2 == 0.0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / length2))
        px, py = ax + t * dx, ay + t * dy
        d = math.hypot(x - px, y - py)
        if d < best:
            best, best_index, best_point = d, i, (px, py)
    total = math.hypot(path[best_index + 1][0] - best_point[0], path[best_index + 1][1] - best_point[1])
    for (ax, ay), (bx, by) in itertools.pairwise(path[best_index + 1 :]):
        total += math.hypot(bx - ax, by - ay)
    return total


def world_planner(world: SimWorld, robot: str) -> Callable[[float, float], list[Point]]:
    """Plans for ``robot`` in ``world`` (around walls and the other robots), refusals as Nav2's error codes."""

    def plan(x: float, y: float) -> list[Point]:
        try:
            return world.plan(robot, x, y)
        except NoPathError as exc:
            raise PlanError(_error_code(world, robot, x, y), str(exc)) from None

    return plan


def _error_code(world: SimWorld, robot: str, x: float, y: float) -> int:
    """Which of ComputePathToPose's codes Nav2's planner_server would give this refusal."""
    state = world.robots[robot].state
    if not world.grid.in_bounds(x, y):
        return GOAL_OUTSIDE_MAP
    if not world.planner.inflated.is_free(x, y):
        return GOAL_OCCUPIED
    near = ROBOT_RADIUS + PLANNING_RADIUS  # another robot there is an obstacle in Nav2's costmap too
    if any(math.hypot(o.state.x - x, o.state.y - y) < near for n, o in world.robots.items() if n != robot):
        return GOAL_OCCUPIED
    if not world.grid.in_bounds(state.x, state.y):
        return START_OUTSIDE_MAP
    return NO_VALID_PATH
