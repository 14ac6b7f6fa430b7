"""How a live backend (``ros``, ``zenoh``) follows its robots' goals and holds them: per robot, Nav2's action
(relay/backends/nav2_goals.py) or a bare goal_pose topic (goal_watch.py), and the word on the watchdog's gate.

It runs on the event loop. The backend gives it a :class:`NavTransport` (how to publish a gate word, send a
CancelGoal request, ask a GetResult) and hands it what arrived from the robots once it has crossed to the loop
(the backend's one crossing). Events go to the relay's sink.

**Stops never wait.** :meth:`Navigation.stop` publishes the gate's word, reports the goal given up and sends the
cancel, and returns; the navigator's answer (or its silence for :data:`CANCEL_TIMEOUT`) arrives later as a
:class:`~relay.fleet.events.CancelAnswerEvent`. Only a new goal waits for an outstanding cancel (at most that long):
``cancel all goals`` reaching Nav2 after the new goal would cancel it too.

**The gate** (robots with a watchdog; docs/reliability.md): ``drive`` just before a goal, ``hold`` on every stop,
``estop`` on an emergency stop, ``drive`` when it is reset, nothing at start-up. A ``hold`` never replaces an
``estop`` (the relay's own, or the one the watchdog reports before this relay said anything): only a reset lifts it.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from typing import Protocol

from ..config import FleetConfig
from ..fleet.events import EventSink, GateStateEvent, GateWord, Goal, PoseEvent
from ..ros.nav2_types import CancelAnswer, Feedback, GoalState, ResultAnswer
from .goal_watch import GoalWatch
from .nav2_goals import Aborted, Nav2Goals

logger = logging.getLogger(__name__)

#: Seconds the navigator has to answer a cancel before the operator is told it did not.
CANCEL_TIMEOUT = 1.0
#: Seconds an aborted goal's result may take: its failure is reported within a second of Nav2's abort either way.
RESULT_TIMEOUT = 0.5
#: Seconds between two looks for goals Nav2 never took.
TICK = 0.25


class NavTransport(Protocol):
    def publish_gate(self, robot: str, word: GateWord) -> None:
        """Publish ``word`` on the robot's gate topic (reliable, transient local)."""

    def request_cancel(self, robot: str) -> asyncio.Future[CancelAnswer | None]:
        """Send a CancelGoal for every goal of the robot's action now; the future gets the answer (None: it
        could not be read)."""

    def request_result(self, robot: str, goal_id: bytes) -> asyncio.Future[ResultAnswer | None] | None:
        """Ask the GetResult of ``goal_id``; None when this backend cannot (no nav2_msgs over DDS)."""


#: How a transport hands what arrived from the robots (Nav2's status and feedback, the watchdog's gate_state) to the
#: backend's Navigation: ``arrive(call)`` runs ``call(navigation)`` on the loop, through the backend's one crossing.
Arrive = Callable[[Callable[["Navigation"], None]], None]


class Navigation:
    def __init__(
        self,
        config: FleetConfig,
        sink: EventSink,
        transport: NavTransport,
        clock: Callable[[], float] = time.monotonic,
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        self._sink = sink
        self._transport = transport
        self._clock = clock
        self._wall_clock = wall_clock  # Nav2 stamps a goal's acceptance with the robot's clock (ROS time)
        self.nav2 = tuple(r.name for r in config.robots if r.nav_interface == "nav2")
        self._goals = Nav2Goals(self.nav2)
        self._watch = GoalWatch()
        self._gated = {r.name for r in config.robots if r.watchdog_topic is not None}
        self._word: dict[str, GateWord] = {}  # what this relay published last
        self._reported: dict[str, GateWord] = {}  # what the watchdog says
        self._cancels: dict[str, asyncio.Task[None]] = {}
        self._tasks: set[asyncio.Task[None]] = set()

    # -- lifecycle --------------------------------------------------------------------------------

    def start(self) -> None:
        if self.nav2:
            self._spawn(self._tick(), "nav2-accept-timeouts")

    async def close(self, wait: float) -> None:
        """Wait up to ``wait`` seconds for the cancels in flight to be answered (shutdown), then stop everything."""
        pending = [t for t in self._cancels.values() if not t.done()]
        if pending:
            await asyncio.wait(pending, timeout=wait)
        for task in [*self._tasks, *self._cancels.values()]:
            task.cancel()

    def _spawn(self, work: object, name: str) -> asyncio.Task[None]:
        task: asyncio.Task[None] = asyncio.get_running_loop().create_task(work, name=name)  # type: ignore[arg-type]
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    async def _tick(self) -> None:
        while True:
            await asyncio.sleep(TICK)
            for event in self._goals.overdue(self._clock()):
                logger.warning("%s: %s", event.robot, event.message)
                self._sink(event)

    # -- the gate ---------------------------------------------------------------------------------

    def _gate(self, robot: str, word: GateWord) -> None:
        if robot not in self._gated:
            return
        current = self._word.get(robot, self._reported.get(robot))
        if (word == "hold" and current == "estop") or word == self._word.get(robot):
            return
        self._word[robot] = word
        try:
            self._transport.publish_gate(robot, word)
        except Exception:
            # A stop goes on whatever happens to the gate (a session being re-opened); the watchdog's heartbeat
            # rule still holds the robot when the relay cannot reach it.
            logger.exception("%s: could not publish %r on the watchdog's gate", robot, word)

    def release(self, robot: str) -> None:
        """An emergency stop was reset: the watchdog lets autonomy through again."""
        self._gate(robot, "drive")

    def gate_state(self, robot: str, word: GateWord) -> None:
        self._reported[robot] = word
        self._sink(GateStateEvent(robot, word))

    # -- goals ------------------------------------------------------------------------------------

    async def before_goal(self, robot: str) -> None:
        """Wait for a cancel still in flight (bounded by its timeout), then open the gate for the goal."""
        cancel = self._cancels.get(robot)
        if cancel is not None and not cancel.done():
            await asyncio.wait([cancel], timeout=CANCEL_TIMEOUT + 0.1)
        self._gate(robot, "drive")

    def sent(self, robot: str, goal: Goal) -> None:
        if robot in self.nav2:
            self._sink(self._goals.sent(robot, goal, self._clock(), wall=self._wall_clock()))
        else:
            self._sink(self._watch.started(robot, goal))

    def stop(self, robot: str, why: str, word: GateWord = "hold") -> None:
        """The robot stops: the gate's word, its goal reported ``cancelled``, and (Nav2) a cancel of every goal sent
        now; nothing here waits for an answer."""
        self._gate(robot, word)
        if robot not in self.nav2:
            if (ended := self._watch.ended(robot, why)) is not None:
                self._sink(ended)
            return
        if (ended := self._goals.give_up(robot, why)) is not None:
            self._sink(ended)
        try:
            answer = self._transport.request_cancel(robot)
        except Exception as exc:
            # No session to send it on (a router being re-opened): said now, as a cancel that went unanswered.
            logger.error("%s: could not send Nav2's cancel: %r", robot, exc)
            answer = asyncio.get_running_loop().create_future()
            answer.set_result(None)
        self._cancels[robot] = self._spawn(self._answer(robot, answer), f"nav2-cancel-{robot}")

    async def _answer(self, robot: str, request: asyncio.Future[CancelAnswer | None]) -> None:
        try:
            answer = await asyncio.wait_for(request, CANCEL_TIMEOUT)
        except TimeoutError:
            answer = None
        event = self._goals.answered(robot, answer, CANCEL_TIMEOUT)
        if event is not None:
            (logger.info if event.confirmed else logger.warning)("%s: %s", robot, event.message)
            self._sink(event)

    def teleop(self, robot: str) -> None:
        """A non-zero velocity: a goal followed on a bare topic ends (Nav2's goals were cancelled by the relay's
        stop when teleop started)."""
        if robot not in self.nav2 and (ended := self._watch.ended(robot, "teleoperation took over")) is not None:
            self._sink(ended)

    # -- what arrived (on the loop) ---------------------------------------------------------------

    def pose(self, event: PoseEvent) -> None:
        if event.robot not in self.nav2 and (reached := self._watch.pose(event)) is not None:
            self._sink(reached)

    def status(self, robot: str, goals: tuple[GoalState, ...]) -> None:
        for outcome in self._goals.status(robot, goals):
            if not isinstance(outcome, Aborted):
                self._sink(outcome)
                continue
            try:
                result = self._transport.request_result(robot, outcome.goal_id)
            except Exception as exc:
                logger.warning("%s: could not ask Nav2 why it aborted: %r", robot, exc)
                result = None
            if result is None:
                self._report_failure(outcome, None)
            else:
                self._spawn(self._result(outcome, result), f"nav2-result-{robot}")

    async def _result(self, aborted: Aborted, request: asyncio.Future[ResultAnswer | None]) -> None:
        answer = None
        with contextlib.suppress(TimeoutError):
            answer = await asyncio.wait_for(request, RESULT_TIMEOUT)
        self._report_failure(aborted, answer)

    def _report_failure(self, aborted: Aborted, answer: ResultAnswer | None) -> None:
        event = self._goals.failed(aborted.robot, aborted, answer)
        if event is not None:
            logger.warning("%s: %s", aborted.robot, event.message)
            self._sink(event)

    def feedback(self, robot: str, feedback: Feedback) -> None:
        if (event := self._goals.feedback(robot, feedback)) is not None:
            self._sink(event)
