"""Missions running in the relay: each robot's steps, one after another, whoever is connected.

A mission goes on when its operator disconnects (the fleet is semi-autonomous): while it runs, the robot's lease is
held by the mission itself (``mission:<id>``), so the operator's leaving does not stop it and another operator
must take the lease over (``force``) to drive the robot by hand, which pauses the mission. Any operator may pause,
resume, skip or abort a mission whose robot the mission holds (or that they hold). An emergency stop holds the
missions of the robots it stops (paused: after the reset an operator resumes or aborts each); a take-over, a
release or any other stop of the relay pauses them. Missions outlive the relay: a restarted relay shows them as
they were (``restore``), paused, and a resume plans the rest again and goes on from the step it was at. A change of
state is announced at once and stored after (``publish``): nothing of a stop waits for the database.

Each step: ``inspect`` and ``goto`` send a goal through the same rules as an operator's (generations: a goal
overtaken by a stop is dropped) and wait for the robot to reach it; ``inspect`` and ``capture`` then take the
camera image and the readings (relay.inspection.capture); ``dwell`` waits. A goal that fails pauses the mission
with the planner's reason. Every change is stored and sent to every client as a ``mission`` message.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Awaitable, Callable
from dataclasses import replace
from typing import Literal

from ..errors import CommandRejected
from ..fleet.events import NavEvent
from .messages import MISSIONS_ON_CONNECT
from .missions import Waypoint
from .records import MissionRecord, Step

logger = logging.getLogger(__name__)

MissionAction = Literal["pause", "resume", "skip", "abort"]
#: Seconds a goal may take before the mission pauses with "took too long" (a robot stuck against an obstacle).
GOAL_TIMEOUT = 300.0


def holder(mission_id: str) -> str:
    """The lease holder name of a running mission."""
    return f"mission:{mission_id}"


class _Interrupted(Exception):
    """The step was cut short: the mission was paused, skipped or aborted meanwhile."""


class MissionRun:
    """One robot's mission: its record, its waypoints, its task."""

    def __init__(self, record: MissionRecord, waypoints: list[Waypoint | None]) -> None:
        self.record = record
        self.waypoints = waypoints
        self.task: asyncio.Task[None] | None = None
        self.changed = asyncio.Event()  # set on every pause, resume, skip, abort
        self.skip = False
        self.nav: asyncio.Future[NavEvent] | None = None


class MissionRunner:
    def __init__(
        self,
        *,
        go: Callable[[str, float, float, float | None], Awaitable[None]],
        stop: Callable[[str], Awaitable[None]],
        capture: Callable[[MissionRecord, Step], Awaitable[None]],
        publish: Callable[[MissionRecord], None],
        release: Callable[[MissionRecord], None],
        wall_clock: Callable[[], float] = time.time,
    ) -> None:
        self._go, self._stop, self._capture, self._publish, self._release = go, stop, capture, publish, release
        self._wall = wall_clock
        self.runs: dict[str, MissionRun] = {}

    # -- queries ----------------------------------------------------------------------------------

    def active(self, robot: str) -> MissionRun | None:
        return next(
            (r for r in self.runs.values() if r.record.robot == robot and r.record.state in ("running", "paused")),
            None,
        )

    def records(self, ended: int = MISSIONS_ON_CONNECT) -> list[MissionRecord]:
        """Every active mission, and the newest ``ended`` of those that ended, oldest first."""
        active = [r.record for r in self.runs.values() if r.record.state not in ("done", "aborted")]
        over = sorted((r.record for r in self.runs.values() if r.record.state in ("done", "aborted")),
                      key=lambda record: record.updated)  # fmt: skip
        return sorted([*active, *over[-ended:]], key=lambda record: record.updated) if ended else active

    def _forget_old(self) -> None:
        """Runs that ended long ago leave memory (they stay in the database and its reports)."""
        ended = [r for r in self.runs.values() if r.record.state in ("done", "aborted")]
        if len(ended) > 2 * MISSIONS_ON_CONNECT:
            for run in sorted(ended, key=lambda r: r.record.updated)[: len(ended) - MISSIONS_ON_CONNECT]:
                del self.runs[run.record.id]

    # -- control ----------------------------------------------------------------------------------

    def start(self, record: MissionRecord, waypoints: list[Waypoint | None]) -> MissionRun:
        run = MissionRun(replace(record, state="running", updated=self._wall()), waypoints)
        self.runs[record.id] = run
        self._forget_old()
        run.task = asyncio.ensure_future(self._run(run))
        return run

    def restore(self, record: MissionRecord) -> MissionRun:
        """A mission from the database (a relay restarted): shown as it was, with no task until it is resumed."""
        run = MissionRun(record, [])
        self.runs[record.id] = run
        return run

    def revive(self, run: MissionRun, waypoints: list[Waypoint | None]) -> None:
        """Resume a restored mission from its current step, with the waypoints planned again from where the robot
        stands now."""
        run.waypoints = waypoints
        self._set(run, "running", "")
        run.task = asyncio.ensure_future(self._run(run))

    def needs_task(self, run: MissionRun) -> bool:
        return run.task is None or run.task.done()

    async def act(self, run: MissionRun, action: MissionAction, by: str) -> None:
        state = run.record.state
        if state in ("done", "aborted"):
            raise ValueError(f"mission {run.record.id} has ended ({state})")
        if action == "pause" and state == "running":
            self._set(run, "paused", f"paused by {by}")
            await self._stop(run.record.robot)
        elif action == "resume" and state == "paused":
            self._set(run, "running", "")
        elif action == "skip":
            run.skip = True
            await self._stop(run.record.robot)
            if state == "paused":
                self._set(run, "running", "")
        elif action == "abort":
            self._set(run, "aborted", f"aborted by {by}")
            await self._stop(run.record.robot)
        run.changed.set()

    def robot_stopped(self, robot: str, reason: str, *, estop: bool) -> None:
        """Control stopped the robot (an estop, a take-over, a release): its mission is paused (held). On the
        estop's path: it awaits nothing (the record is written after, relay.inspection.write_behind)."""
        run = self.active(robot)
        if run is None:
            return
        if estop:
            # Held, not aborted: after the reset an operator resumes it from where it was, or aborts it.
            self._set(run, "paused", f"{reason}; held: resume after the reset, or abort")
        elif run.record.state == "running":
            self._set(run, "paused", reason)
        run.changed.set()

    def on_nav(self, event: NavEvent) -> None:
        run = self.active(event.robot)
        if run is not None and run.nav is not None and not run.nav.done() and event.outcome != "started":
            run.nav.set_result(event)

    async def stop(self) -> None:
        """Shutdown: every running mission is left paused (stored so), its task cancelled."""
        for run in list(self.runs.values()):
            if run.record.state == "running":
                self._set(run, "paused", "the relay stopped")
            if run.task is not None:
                run.task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await run.task

    # -- the run ----------------------------------------------------------------------------------

    def _set(self, run: MissionRun, state: str, reason: str, current: int | None = None) -> None:
        run.record = replace(
            run.record,
            state=state,  # type: ignore[arg-type]
            reason=reason,
            current=run.record.current if current is None else current,
            updated=self._wall(),
        )
        if state in ("done", "aborted"):
            self._release(run.record)
        self._publish(run.record)

    async def _run(self, run: MissionRun) -> None:
        try:
            self._publish(run.record)
            while run.record.current < len(run.record.steps):
                if run.record.state == "aborted":
                    return
                if run.record.state == "paused":
                    run.changed.clear()
                    await run.changed.wait()
                    continue
                index = run.record.current
                try:
                    await self._step(run, run.record.steps[index], run.waypoints[index])
                except _Interrupted:
                    if run.skip:
                        run.skip = False
                        self._set(run, run.record.state, f"step {index + 1} skipped", current=index + 1)
                    continue
                self._set(run, "running", "", current=index + 1)
            self._set(run, "done", "")
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a store that is full, a camera that fails: the operator must learn why
            logger.exception("mission %s failed", run.record.id)
            with contextlib.suppress(Exception):
                self._set(run, "paused", f"the relay failed on this step: {exc}")
                await self._stop(run.record.robot)

    def _check(self, run: MissionRun) -> None:
        if run.record.state != "running" or run.skip:
            raise _Interrupted()

    async def _step(self, run: MissionRun, step: Step, waypoint: Waypoint | None) -> None:
        self._check(run)
        if waypoint is not None:
            await self._drive(run, waypoint)
        if step.kind in ("inspect", "capture"):
            self._check(run)
            await self._capture(run.record, step)
        if step.kind == "dwell":
            assert step.seconds is not None
            run.changed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(run.changed.wait(), step.seconds)
            self._check(run)

    async def _drive(self, run: MissionRun, waypoint: Waypoint) -> None:
        loop = asyncio.get_running_loop()
        run.nav = loop.create_future()
        run.changed.clear()
        try:
            await self._go(run.record.robot, waypoint.x, waypoint.y, waypoint.yaw)
        except CommandRejected as exc:  # the backend refused the goal (no path now, a robot in the way): say why
            self._set(run, "paused", f"step {run.record.current + 1}: {exc}")
            raise _Interrupted() from None
        changed: asyncio.Future[object] = asyncio.ensure_future(run.changed.wait())
        waiting: set[asyncio.Future[object]] = {run.nav, changed}  # type: ignore[arg-type]
        try:
            done, _ = await asyncio.wait(waiting, timeout=GOAL_TIMEOUT, return_when=asyncio.FIRST_COMPLETED)
        finally:
            changed.cancel()
        self._check(run)
        if run.nav not in done and changed in done:
            raise _Interrupted()  # paused and resumed meanwhile: the step starts over
        if run.nav not in done:
            await self._stop(run.record.robot)
            self._set(run, "paused", f"step {run.record.current + 1}: the goal took over {GOAL_TIMEOUT:g} s")
            raise _Interrupted()
        event = run.nav.result()
        if event.outcome != "reached":
            self._set(
                run, "paused", f"step {run.record.current + 1}: {event.outcome}: {event.message or 'goal not reached'}"
            )
            raise _Interrupted()
