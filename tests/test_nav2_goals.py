"""Which Nav2 goal is the relay's and how it ends (relay/backends/nav2_goals.py, pure), and the loop side that the ros
and zenoh backends share (relay/backends/navigation.py): gate words, cancels that never make a stop wait, answers
that come later or not at all, an aborted goal's reason from its result."""

from __future__ import annotations

import asyncio

from relay.backends.nav2_goals import ACCEPT_TIMEOUT, Aborted, Nav2Goals
from relay.backends.navigation import CANCEL_TIMEOUT, Navigation
from relay.config import parse_config
from relay.fleet.events import CancelAnswerEvent, Event, GateStateEvent, GateWord, NavEvent, NavFeedbackEvent
from relay.ros.nav2_types import (
    STATUS_ABORTED,
    STATUS_ACCEPTED,
    STATUS_CANCELED,
    STATUS_EXECUTING,
    STATUS_SUCCEEDED,
    CancelAnswer,
    Feedback,
    GoalState,
    ResultAnswer,
)
from tests.helpers.waiting import wait_until

OLD, A, B = b"o" * 16, b"a" * 16, b"b" * 16
GOAL = (9.0, 6.0, None)


def test_the_first_new_goal_after_a_send_is_ours_and_its_success_is_reached() -> None:
    goals = Nav2Goals(["r"])
    # Before any goal: a finished goal of someone else's, then ours is sent.
    assert goals.status("r", (GoalState(OLD, 10.0, STATUS_SUCCEEDED),)) == []
    assert goals.sent("r", GOAL, 100.0) == NavEvent("r", True, GOAL, "started")
    assert goals.feedback("r", Feedback(A, 3.0, 6.0, 0, 1.0)) is None  # not known as ours yet
    assert goals.status("r", (GoalState(OLD, 10.0, STATUS_SUCCEEDED), GoalState(A, 20.0, STATUS_EXECUTING))) == []
    assert goals.feedback("r", Feedback(A, 3.0, 6.0, 1, 2.0)) == NavFeedbackEvent("r", GOAL, 3.0, 6.0, 1, 2.0)
    assert goals.feedback("r", Feedback(OLD, 3.0, 6.0, 1, 2.0)) is None
    assert goals.status("r", (GoalState(A, 20.0, STATUS_SUCCEEDED),)) == [
        NavEvent("r", False, GOAL, "reached", "Nav2: goal succeeded")
    ]
    assert not goals.following("r")
    assert goals.status("r", (GoalState(A, 20.0, STATUS_SUCCEEDED),)) == []  # said once


def test_a_finished_goal_in_the_first_status_heard_is_never_taken_for_ours() -> None:
    goals = Nav2Goals(["r"])
    goals.sent("r", GOAL, 0.0)  # sent before any status arrived (a relay just started)
    assert goals.status("r", (GoalState(OLD, 1.0, STATUS_ABORTED),)) == []  # an old result, not ours
    assert goals.status("r", (GoalState(OLD, 1.0, STATUS_ABORTED), GoalState(A, 2.0, STATUS_ACCEPTED))) == []
    [aborted] = goals.status("r", (GoalState(A, 2.0, STATUS_ABORTED),))
    assert aborted == Aborted("r", A, GOAL)
    # Sent before the first status, ours may be in it already, running.
    goals = Nav2Goals(["r"])
    goals.sent("r", GOAL, 0.0)
    assert goals.status("r", (GoalState(OLD, 1.0, STATUS_SUCCEEDED), GoalState(A, 2.0, STATUS_EXECUTING))) == []
    assert goals.feedback("r", Feedback(A, 1.0, 1.0, 0, 1.0)) is not None


def test_a_goal_aborted_at_once_in_the_first_status_heard_is_ours_when_nav2_accepted_it_after_the_send() -> None:
    """A goal in a wall: Nav2 aborts it at once, and the first status the relay hears lists it already ABORTED. Taken
    for an old result, it went unreported for 5 s and then failed as "never listed", without Nav2's reason."""
    goals = Nav2Goals(["r"])
    goals.sent("r", GOAL, 0.0, wall=1000.0)
    [aborted] = goals.status("r", (GoalState(OLD, 900.0, STATUS_ABORTED), GoalState(A, 1000.2, STATUS_ABORTED)))
    assert aborted == Aborted("r", A, GOAL)
    # Accepted by a robot whose clock is half a second behind the station's: still ours.
    goals = Nav2Goals(["r"])
    goals.sent("r", GOAL, 0.0, wall=1000.0)
    assert goals.status("r", (GoalState(A, 999.5, STATUS_ABORTED),)) == [Aborted("r", A, GOAL)]
    # Accepted well before the send: an old result, not ours.
    goals = Nav2Goals(["r"])
    goals.sent("r", GOAL, 0.0, wall=1000.0)
    assert goals.status("r", (GoalState(OLD, 990.0, STATUS_ABORTED),)) == []


def test_a_preempted_goal_says_nothing_and_an_abort_is_reported_with_nav2s_reason() -> None:
    goals = Nav2Goals(["r"])
    goals.status("r", ())
    goals.sent("r", GOAL, 0.0)
    goals.status("r", (GoalState(A, 1.0, STATUS_EXECUTING),))
    second = (1.0, 2.0, 0.5)
    goals.sent("r", second, 1.0)
    # Nav2 aborts the goal the newer one preempted: it is not ours any more.
    assert goals.status("r", (GoalState(A, 1.0, STATUS_ABORTED), GoalState(B, 2.0, STATUS_EXECUTING))) == []
    [aborted] = goals.status("r", (GoalState(A, 1.0, STATUS_ABORTED), GoalState(B, 2.0, STATUS_ABORTED)))
    assert isinstance(aborted, Aborted) and aborted == Aborted("r", B, second)
    assert goals.failed("r", aborted, ResultAnswer(STATUS_ABORTED, 208, "no path")) == NavEvent(
        "r", False, second, "failed",
        "Nav2 aborted the goal: no path [error 208 (ComputePathToPose: no valid path)]", 208,
    )  # fmt: skip
    assert goals.failed("r", aborted, None) is None  # reported once
    # No result to be had (DDS without nav2_msgs): still failed, at once.
    goals.sent("r", GOAL, 2.0)
    [aborted] = goals.status("r", (GoalState(A, 3.0, STATUS_ABORTED), GoalState(B, 2.0, STATUS_ABORTED),
                                   GoalState(OLD, 5.0, STATUS_ABORTED)))  # fmt: skip
    assert isinstance(aborted, Aborted)
    assert goals.failed("r", aborted, None) == NavEvent("r", False, GOAL, "failed", "Nav2 aborted the goal")
    # A newer goal while the result of an aborted one is asked: the old failure is not reported over it.
    goals.sent("r", GOAL, 3.0)
    [aborted] = goals.status("r", (GoalState(b"c" * 16, 6.0, STATUS_ABORTED),))
    assert isinstance(aborted, Aborted)
    goals.sent("r", second, 3.1)
    assert goals.failed("r", aborted, None) is None


def test_cancels_report_the_goal_given_up_and_the_navigators_answer() -> None:
    goals = Nav2Goals(["r"])
    goals.status("r", ())
    goals.sent("r", GOAL, 0.0)
    goals.status("r", (GoalState(A, 1.0, STATUS_EXECUTING),))
    assert goals.give_up("r", "emergency stop") == NavEvent("r", False, GOAL, "cancelled", "emergency stop")
    # Its CANCELED status afterwards is not news.
    assert goals.status("r", (GoalState(A, 1.0, STATUS_CANCELED),)) == []
    assert goals.answered("r", CancelAnswer(0, (A,)), 1.0) == CancelAnswerEvent(
        "r", GOAL, True, "Nav2 is cancelling 1 goal"
    )
    # No answer within the timeout.
    goals.sent("r", GOAL, 2.0)
    goals.status("r", (GoalState(B, 2.0, STATUS_EXECUTING),))
    goals.give_up("r", "cancelled")
    assert goals.answered("r", None, 1.0) == CancelAnswerEvent(
        "r", GOAL, False, "Nav2 did not answer the cancel within 1 s"
    )
    # Refused while the goal still runs; "nothing to cancel" once it had ended.
    goals.sent("r", GOAL, 3.0)
    goals.status("r", (GoalState(b"c" * 16, 3.0, STATUS_EXECUTING),))
    goals.give_up("r", "cancelled")
    assert goals.answered("r", CancelAnswer(1, ()), 1.0) == CancelAnswerEvent(
        "r", GOAL, False, "Nav2 refused the cancel (ERROR_REJECTED)"
    )
    goals.sent("r", GOAL, 4.0)
    goals.status("r", (GoalState(b"d" * 16, 4.0, STATUS_SUCCEEDED),))
    assert goals.give_up("r", "cancelled") is None  # it had been reached
    assert goals.answered("r", CancelAnswer(1, ()), 1.0) is None  # an idle robot's cancel says nothing
    # A goal cancelled by someone else (RViz, another relay) ends cancelled too.
    goals.sent("r", GOAL, 5.0)
    assert goals.status("r", (GoalState(b"e" * 16, 5.0, STATUS_CANCELED),))[0] == NavEvent(
        "r", False, GOAL, "cancelled", "Nav2 cancelled the goal (not asked by this relay)"
    )


def test_a_goal_nav2_never_lists_fails_after_the_accept_timeout() -> None:
    goals = Nav2Goals(["r", "s"])
    goals.sent("r", GOAL, 100.0)
    assert goals.overdue(100.0 + ACCEPT_TIMEOUT - 0.1) == []
    [event] = goals.overdue(100.0 + ACCEPT_TIMEOUT + 0.1)
    assert (event.outcome, event.navigating) == ("failed", False)
    assert "did not take the goal within 5 s (heard no status from Nav2" in event.message
    assert goals.overdue(200.0) == []


FLEET = """
robots:
  - {name: nav, limits: {linear: 1, angular: 1}, cmd_vel: {watchdog: true}}
  - {name: bare, limits: {linear: 1, angular: 1}, navigation: topic}
"""


class Transport:
    """What Navigation asks of a backend, recorded; answers are given by the test."""

    def __init__(self) -> None:
        self.words: list[tuple[str, GateWord]] = []
        self.cancels: list[asyncio.Future[CancelAnswer | None]] = []
        self.results: list[asyncio.Future[ResultAnswer | None]] = []

    def publish_gate(self, robot: str, word: GateWord) -> None:
        self.words.append((robot, word))

    def request_cancel(self, robot: str) -> asyncio.Future[CancelAnswer | None]:
        self.cancels.append(asyncio.get_running_loop().create_future())
        return self.cancels[-1]

    def request_result(self, robot: str, goal_id: bytes) -> asyncio.Future[ResultAnswer | None] | None:
        self.results.append(asyncio.get_running_loop().create_future())
        return self.results[-1]


async def test_stops_publish_the_gate_send_the_cancel_at_once_and_report_its_answer_later() -> None:
    events: list[Event] = []
    transport = Transport()
    nav = Navigation(parse_config(FLEET), events.append, transport)
    nav.start()
    try:
        await nav.before_goal("nav")
        nav.sent("nav", GOAL)
        nav.status("nav", (GoalState(A, 1.0, STATUS_EXECUTING),))
        nav.stop("nav", "emergency stop", "estop")  # returns at once: the cancel is sent, not awaited
        assert transport.words == [("nav", "drive"), ("nav", "estop")] and len(transport.cancels) == 1
        assert events[-1] == NavEvent("nav", False, GOAL, "cancelled", "emergency stop")
        nav.stop("nav", "cancelled")  # a later stop (shutdown, a take-over): hold never lifts an estop
        assert transport.words[-1] == ("nav", "estop")
        transport.cancels[0].set_result(CancelAnswer(0, (A,)))
        # The answer reaches the event a few loop turns later: a fixed 10 ms sleep lost that race on a loaded CI.
        answered = CancelAnswerEvent("nav", GOAL, True, "Nav2 is cancelling 1 goal")
        await wait_until(lambda: answered in events, 5.0, "the cancel's answer as an event")
        nav.release("nav")
        nav.stop("nav", "lease expired")
        assert transport.words[-2:] == [("nav", "drive"), ("nav", "hold")]
        # A new goal waits for the cancel in flight (unanswered: at most its timeout), then opens the gate.
        loop = asyncio.get_running_loop()
        started = loop.time()
        await nav.before_goal("nav")
        assert CANCEL_TIMEOUT - 0.05 <= loop.time() - started <= CANCEL_TIMEOUT + 0.5
        assert transport.words[-1] == ("nav", "drive")
        # An abort: the result is asked, and the failure names Nav2's reason.
        nav.sent("nav", GOAL)
        nav.status("nav", (GoalState(B, 2.0, STATUS_EXECUTING),))
        nav.status("nav", (GoalState(B, 2.0, STATUS_ABORTED),))
        transport.results[-1].set_result(ResultAnswer(STATUS_ABORTED, 105, "stuck"))
        await wait_until(lambda: isinstance(events[-1], NavEvent) and events[-1].outcome == "failed", 5.0, "the abort")
        failed = events[-1]
        assert isinstance(failed, NavEvent) and failed.outcome == "failed" and failed.error_code == 105
        # A bare goal_pose robot: no gate (no watchdog), no cancel; its goal ends by pose or by a stop.
        nav.sent("bare", GOAL)
        nav.stop("bare", "cancelled")
        assert events[-1] == NavEvent("bare", False, GOAL, "cancelled", "cancelled")
        assert all(robot == "nav" for robot, _ in transport.words) and len(transport.cancels) == 3
        # The watchdog's word reaches the relay as an event; an estop it reports before this relay said anything
        # is never lifted by a hold.
        fresh = Navigation(parse_config(FLEET), events.append, transport)
        fresh.gate_state("nav", "estop")
        assert GateStateEvent("nav", "estop") in events
        count = len(transport.words)
        fresh.stop("nav", "shutdown")
        assert len(transport.words) == count
        fresh.release("nav")
        assert transport.words[-1] == ("nav", "drive")
    finally:
        await nav.close(0.0)
