"""Which Nav2 goal is the one the relay sent, and how it ends: a pure rule, fed Nav2's action status, feedback and
answers, with the time passed in. Shared by the ``ros`` and ``zenoh`` backends (relay/backends/navigation.py).

The relay sends a goal as a PoseStamped on ``goal_pose``; Nav2's bt_navigator turns it into a NavigateToPose goal
with an id of its own, which the relay never sees sent. So **the goal that is ours** is the first goal id that
appears on ``<action>/_action/status`` after the relay sent one (the newest by its accepted stamp, should several
appear at once). Goals already there before (another client's, an earlier one's result) are never ours: ids in
the first status array a robot sends are remembered unless they are still running and a goal of ours waits (the
relay may send a goal before it has heard any status). Nav2 aborts the goal a newer one preempts: that goal is no
longer ours by then, and says nothing.

Outcomes: SUCCEEDED -> ``reached``; ABORTED -> ``failed`` (the backend may ask GetResult for Nav2's error first:
:meth:`Nav2Goals.status` returns an :class:`Aborted` for it); CANCELED that the relay did not ask for ->
``cancelled``. A goal no status names within :data:`ACCEPT_TIMEOUT` -> ``failed`` (no navigator took it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..fleet.events import CancelAnswerEvent, Goal, NavEvent, NavFeedbackEvent
from ..ros.nav2_types import (
    ACTIVE,
    CANCEL_ERROR_NONE,
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    CancelAnswer,
    Feedback,
    GoalState,
    ResultAnswer,
    failure_reason,
)

#: Seconds a goal sent on goal_pose may wait for Nav2 to list it before it is reported failed. Nav2 lists a goal
#: within milliseconds of accepting it; 5 s leaves room for a first DDS match on a loaded machine.
ACCEPT_TIMEOUT = 5.0
#: How far the robot's clock may be behind the station's for a goal in the first status heard, already ended, to be
#: taken for the one just sent. Nav2 lists a goal it aborts at once (a goal in a wall) first as ABORTED: without this
#: it went unreported for ACCEPT_TIMEOUT, then as "never listed". A robot clock further behind falls back to that.
CLOCK_SKEW = 1.0


@dataclass(frozen=True, slots=True)
class Aborted:
    """Nav2 aborted the robot's goal: the backend may ask its result (:meth:`Nav2Goals.failed` then reports it)."""

    robot: str
    goal_id: bytes
    goal: Goal


@dataclass
class _Robot:
    seen: set[bytes] = field(default_factory=set)
    heard: bool = False  # a status array has arrived
    last: dict[bytes, int] = field(default_factory=dict)  # the latest array's statuses
    goal: Goal | None = None  # the goal the relay sent and follows
    sent_at: float = 0.0
    sent_wall: float | None = None  # the station's wall clock at the send, when the backend tells it
    ours: bytes | None = None  # its Nav2 id, once a status named it
    aborted: bytes | None = None  # an aborted goal whose result is being asked
    given_up: tuple[Goal | None, bytes | None] | None = None  # a cancel's goal and id, until its answer


class Nav2Goals:
    def __init__(self, robots: tuple[str, ...] | list[str]) -> None:
        self._robots = {name: _Robot() for name in robots}

    def following(self, robot: str) -> bool:
        """Whether the robot follows a goal of the relay's (sent, not ended)."""
        return self._robots[robot].goal is not None

    def sent(self, robot: str, goal: Goal, now: float, wall: float | None = None) -> NavEvent:
        r = self._robots[robot]
        if r.ours is not None:
            r.seen.add(r.ours)
        r.goal, r.sent_at, r.sent_wall, r.ours, r.aborted = goal, now, wall, None, None
        return NavEvent(robot, True, goal, "started")

    def status(self, robot: str, goals: tuple[GoalState, ...]) -> list[NavEvent | Aborted]:
        """A GoalStatusArray: the outcome of the robot's goal, when this array tells it."""
        r = self._robots[robot]
        new = [g for g in goals if g.goal_id not in r.seen and g.goal_id != r.ours]
        first = not r.heard
        r.heard = True
        r.last = {g.goal_id: g.status for g in goals}
        if r.goal is not None and r.ours is None:
            # In the first array heard, ended goals may be old ones (it is transient local): only a running one, or
            # one Nav2 accepted after the send, is ours.
            since = None if r.sent_wall is None else r.sent_wall - CLOCK_SKEW
            candidates = [
                g for g in new if not first or g.status in ACTIVE or (since is not None and g.accepted >= since)
            ]
            if candidates:
                r.ours = max(candidates, key=lambda g: g.accepted).goal_id
        r.seen.update(g.goal_id for g in new if g.goal_id != r.ours)
        status = r.last.get(r.ours) if r.ours is not None else None
        if status is None or r.goal is None or r.ours is None:
            return []
        goal, ours = r.goal, r.ours
        if status == STATUS_SUCCEEDED:
            self._end(r)
            return [NavEvent(robot, False, goal, "reached", "Nav2: goal succeeded")]
        if status == STATUS_ABORTED:
            self._end(r)
            r.aborted = ours
            return [Aborted(robot, ours, goal)]
        if status == STATUS_CANCELED:
            self._end(r)
            return [NavEvent(robot, False, goal, "cancelled", "Nav2 cancelled the goal (not asked by this relay)")]
        return []

    @staticmethod
    def _end(r: _Robot) -> None:
        if r.ours is not None:
            r.seen.add(r.ours)
        r.goal, r.ours = None, None

    def failed(self, robot: str, aborted: Aborted, answer: ResultAnswer | None) -> NavEvent | None:
        """The report of an aborted goal, with Nav2's error when its result was had; None when a newer goal came
        meanwhile (the robot follows that one now)."""
        r = self._robots[robot]
        if r.aborted != aborted.goal_id:
            return None
        r.aborted = None
        if answer is None:
            return NavEvent(robot, False, aborted.goal, "failed", "Nav2 aborted the goal")
        reason = failure_reason(answer.error_code, answer.error_msg)
        return NavEvent(robot, False, aborted.goal, "failed", f"Nav2 aborted the goal: {reason}", answer.error_code)

    def feedback(self, robot: str, feedback: Feedback) -> NavFeedbackEvent | None:
        r = self._robots[robot]
        if r.goal is None or feedback.goal_id != r.ours:
            return None
        return NavFeedbackEvent(
            robot, r.goal, feedback.distance_remaining, feedback.eta, feedback.recoveries, feedback.navigation_time
        )

    def give_up(self, robot: str, why: str) -> NavEvent | None:
        """The relay stops the robot (and asks Nav2 to cancel every goal): its goal, if any, ends ``cancelled``."""
        r = self._robots[robot]
        goal, ours = r.goal, r.ours
        if goal is not None or r.given_up is None:  # a second stop before the answer keeps the goal to report
            r.given_up = (goal, ours)
        self._end(r)  # an aborted goal whose result is being asked is still reported failed
        return None if goal is None else NavEvent(robot, False, goal, "cancelled", why)

    def answered(self, robot: str, answer: CancelAnswer | None, timeout: float) -> CancelAnswerEvent | None:
        """The navigator's answer to the relay's cancel (None: none within ``timeout`` seconds). Reported when the
        relay had given a goal up or the navigator says it cancelled one; a cancel of an idle robot says nothing."""
        r = self._robots[robot]
        goal, ours = r.given_up if r.given_up is not None else (None, None)
        r.given_up = None
        running = ours is not None and r.last.get(ours) in ACTIVE
        if goal is None and (answer is None or not answer.goals_canceling):
            return None
        if answer is None:
            return CancelAnswerEvent(robot, goal, False, f"Nav2 did not answer the cancel within {timeout:g} s")
        count = len(answer.goals_canceling)
        if answer.return_code == CANCEL_ERROR_NONE:
            return CancelAnswerEvent(robot, goal, True, f"Nav2 is cancelling {count} goal{'s' * (count != 1)}")
        if running:
            return CancelAnswerEvent(robot, goal, False, f"Nav2 refused the cancel ({answer.code_name})")
        return CancelAnswerEvent(robot, goal, True, f"Nav2 had no goal left to cancel ({answer.code_name})")

    def overdue(self, now: float) -> list[NavEvent]:
        """Goals no status has named within ACCEPT_TIMEOUT: reported failed, and no longer followed."""
        events = []
        for robot, r in self._robots.items():
            if r.goal is not None and r.ours is None and now - r.sent_at > ACCEPT_TIMEOUT:
                goal = r.goal
                r.goal = None
                why = "heard no status from Nav2" if not r.heard else "no new goal in Nav2's status"
                events.append(
                    NavEvent(
                        robot, False, goal, "failed",
                        f"Nav2 did not take the goal within {ACCEPT_TIMEOUT:g} s ({why}: is its bt_navigator running "
                        "and subscribed to this robot's goal_pose?)",
                    )
                )  # fmt: skip
        return events
