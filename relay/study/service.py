"""The study the relay runs (``--study FILE``, issue #34): the participant's run driven by the relay's own events.

- **Commands** (relay/study/wire.py): ``study/join`` makes a client the participant's station and their run (new, or
  as it was left, across a restart of the relay) the active one; ``study/start`` applies the task's start state (the
  estop reset, simulated robots placed) and starts its clock; ``study/answer`` takes the participant's answers to a
  questionnaire or a probe. Joining and starting need an operator's role; answers come from the participant's client.
- **What feeds the run**: a ticker (every ``TICK`` of the relay's clock) passes the fleet's poses and modes for the
  task's time, its success (relay/study/rules.py) and near-collisions; the session hands every command's outcome
  and every viewpoint's view, inspection every finding marked, the event router every goal reached
  (relay/study/observer.py). None of it is on a stop's path: the hooks count and return.
- **Every change** is sent to every client as a ``study`` message and saved (relay/study/store.py): the run's JSON
  is written whole off the loop by one writer, the newest state of each participant waiting, so that at most one
  write per participant is ever queued.

Time is the relay's ``clock``, passed in: tests move it by hand.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Final

from ..accounts.roles import may
from ..errors import CommandRejected, ConfigError, ProtocolError
from ..fleet.occupancy import OccupancyGrid
from ..wire.fields import ErrorCode, RequestId
from .model import GoalReached, Probe, RobotInRegion, Study
from .observer import StudyEvents
from .probes import choices, truth
from .run import StudyError, StudyRun
from .scores import AnswerError
from .store import RunStore
from .study_file import load_study
from .wire import StudyAnswer, StudyJoin, StudyMessage, StudyPhase, StudyProbe, StudyStart, study_message
from .writer import RunWriter

if TYPE_CHECKING:
    from ..backends.base import Backend
    from ..control.control import Control
    from ..fleet.state import FleetState
    from ..session.clients import Client
    from ..station.messages import RoomDescription
    from ..station.outbox import Outbox

logger = logging.getLogger(__name__)

#: How often a task's time, success and near-collisions are judged (s of the relay's clock): a success is seen at
#: most this late after the pose that made it.
TICK: Final = 0.05
#: A robot's footprint radius for near-collisions (m): the simulated robots' (relay/sim/world.py ROBOT_RADIUS).
ROBOT_RADIUS: Final = 0.2


class StudyService:
    """The active run of the relay's study (none without ``--study``), the commands that drive it and its hooks."""

    def __init__(
        self,
        path: str | None,
        runs: Path,
        robots: Sequence[str],
        *,
        backend: Backend,
        control: Control,
        fleet: FleetState,
        outbox: Outbox,
        map_grid: Callable[[], OccupancyGrid | None],
        rooms: Callable[[], Sequence[RoomDescription]],
        clock: Callable[[], float],
        events: StudyEvents,
    ) -> None:
        self.path, self.runs_folder, self.robots = path, runs, list(robots)
        self.backend, self.control, self.fleet, self.outbox = backend, control, fleet, outbox
        self.map_grid, self.rooms, self.clock = map_grid, rooms, clock
        self.study: Study | None = None
        self.store: RunStore | None = None
        self.client_id: str | None = None  # the participant's client: where answers come from
        self._runs: dict[str, StudyRun] = {}  # every run loaded in this process, by participant
        self._lock = asyncio.Lock()  # one study command at a time (they await robots and files between checks)
        self.writer: RunWriter | None = None
        self._ticking: asyncio.Task[None] | None = None
        #: What the relay's events count in the task running (the session's, inspection's, the router's hooks).
        self.events = events

    @property
    def run(self) -> StudyRun | None:
        """The active run: the one the relay's events count in."""
        return self.events.active

    @run.setter
    def run(self, run: StudyRun | None) -> None:
        self.events.active = run

    # -- lifecycle ------------------------------------------------------------------------------------------------

    async def start(self) -> None:
        """Read the study file (a bad one raises ConfigError naming the line and field) and the active run as it was
        left; then the ticker and the writer."""
        if self.path is None:
            return
        study = await asyncio.to_thread(load_study, self.path)
        check_robots(study, self.robots, str(self.path))
        self.study, self.store = study, RunStore(self.runs_folder, study)
        self.writer = RunWriter(self.store)
        run = await asyncio.to_thread(self._restore, self.store)
        if run is not None:
            self._runs[run.state.participant] = self.run = run
            self._save(run)  # a task it was in restarts: counted in its file at once
            logger.info("study %s: %s's run restored at %s", study.name, run.state.participant, run.state.phase)
        self.writer.start()
        self._ticking = asyncio.get_running_loop().create_task(self._ticker(), name="study-ticker")
        logger.info("study %s: %d participants, %d tasks", study.name, len(study.participants), len(study.tasks))

    @staticmethod
    def _restore(store: RunStore) -> StudyRun | None:
        active = store.active()
        return store.load(active) if active is not None else None

    async def stop(self) -> None:
        if self._ticking is not None:
            self._ticking.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._ticking
            self._ticking = None
        if self.writer is not None:
            await self.writer.close()

    # -- what clients see -----------------------------------------------------------------------------------------

    def on_connect(self, client: Client) -> None:
        if self.study is not None:
            self.outbox.to(client, self.message())

    def message(self) -> StudyMessage:
        assert self.study is not None
        study, run = self.study, self.run
        participants = list(study.participants)
        if run is None:
            return study_message(study=study.name, phase="waiting", participants=participants)
        phase: StudyPhase = run.state.phase
        total = len(study.conditions) * len(study.tasks)
        done = sum(1 for r in run.state.rows if r["measure"] == "time_s")
        ended = phase == "done"
        probe: StudyProbe | None = None
        if run.probe is not None:
            asked = run.probe[0]
            probe = {"question": asked.question, "robot": asked.robot, "choices": self._choices(asked)}
        pending = run.state.pending[0] if phase == "questions" and run.state.pending else None
        elapsed = run.elapsed if phase in ("task", "probe", "questions") else 0.0  # the task's, or the one just done
        return study_message(
            study=study.name, phase=phase, participants=participants, participant=run.state.participant,
            condition=None if ended else run.condition, settings={} if ended else run.settings,
            task=None if ended else run.task.name, instruction=None if ended else run.task.instruction,
            time_limit=None if ended else run.task.time_limit, elapsed=elapsed, questionnaire=pending, probe=probe,
            done=done, total=total,
        )  # fmt: skip

    def _changed(self, run: StudyRun) -> None:
        self._save(run)
        self.outbox.broadcast(self.message())

    # -- commands -------------------------------------------------------------------------------------------------

    async def handle(self, client: Client, command: StudyJoin | StudyStart | StudyAnswer, now: float) -> None:
        """Carry out a study command and acknowledge it; a refusal raises ProtocolError and changes nothing."""
        if self.study is None or self.store is None:
            raise ProtocolError(
                ErrorCode.UNSUPPORTED, f"{command.identifier}: this relay runs no study (start it with --study FILE)"
            )
        async with self._lock:
            try:
                if isinstance(command, StudyJoin):
                    await self._join(client, command, self.study, self.store)
                elif isinstance(command, StudyStart):
                    await self._start(client, command)  # its clock starts once its robots are placed
                else:
                    self._answer(client, command, now)
            except (StudyError, AnswerError) as exc:
                raise ProtocolError(ErrorCode.BAD_REQUEST, f"{command.identifier}: {exc}", command.id) from None
        self.outbox.ack(client, command.id)

    @staticmethod
    def _require_operator(client: Client, identifier: str, request_id: RequestId) -> None:
        if not may(client.role, "drive"):
            raise ProtocolError(
                ErrorCode.FORBIDDEN, f"{identifier}: only an operator or an admin runs a study", request_id
            )

    async def _join(self, client: Client, command: StudyJoin, study: Study, store: RunStore) -> None:
        self._require_operator(client, command.identifier, command.id)
        participant = command.participant
        if participant not in study.participants:
            raise StudyError(f"{participant!r} is not a participant of {study.name} ({', '.join(study.participants)})")
        active = self.run
        if active is not None and active.state.participant != participant and active.state.phase in ("task", "probe"):
            raise StudyError(f"{active.state.participant} is in a task ({active.task.name}); it ends first")
        known = self._runs.get(participant)
        run = known if known is not None else await asyncio.to_thread(store.load, participant)
        self._runs[participant] = run
        self.run = run
        self.client_id = client.client_id
        self._save(run, active=True)
        logger.info("study %s: %s joined from %s", study.name, participant, client.client_id)
        self.outbox.broadcast(self.message())

    async def _start(self, client: Client, command: StudyStart) -> None:
        self._require_operator(client, command.identifier, command.id)
        run = self.run
        if run is None:
            raise StudyError("no participant has joined (study/join first)")
        if run.state.phase != "ready":
            raise StudyError(f"a task starts from its instruction; the run is at {run.state.phase}")
        start = run.task.start
        if start.reset_estop and self.control.latched:
            refusal = self.control.reset_refusal(None, client.user or client.client_id, client.role == "admin")
            if refusal is not None:
                raise ProtocolError(ErrorCode.FORBIDDEN, f"{command.identifier}: {refusal}", command.id)
        for pose in start.poses:  # every pose checked before anything moves
            cannot = self.backend.place_refusal(pose.robot, pose.x, pose.y)
            if cannot is not None:
                raise ProtocolError(cannot.code, f"{command.identifier}: {cannot.message}", command.id)
        for pose in start.poses:
            await self.control.halt(pose.robot, f"study task {run.task.name} starts")
            try:
                await self.backend.place(pose.robot, pose.x, pose.y, pose.yaw)
            except CommandRejected as exc:
                raise ProtocolError(exc.code, f"{command.identifier}: {exc.message}", command.id) from None
        if start.reset_estop and self.control.latched:
            self.control.reset_estop(None, client.client_id, self.clock())
        run.begin(self.clock())
        logger.info("study: %s starts %s under %s", run.state.participant, run.task.name, run.condition)
        self._changed(run)

    def _answer(self, client: Client, command: StudyAnswer, now: float) -> None:
        run = self.run
        if run is None:
            raise StudyError("no participant has joined (study/join first)")
        if client.client_id != self.client_id:
            raise ProtocolError(
                ErrorCode.FORBIDDEN,
                f"{command.identifier}: answers come from {run.state.participant}'s client (the one that joined)",
                command.id,
            )
        if command.probe is not None:
            if run.probe is None:
                raise StudyError("no probe is asked now")
            choices = self._choices(run.probe[0])
            if command.probe not in choices:
                raise StudyError(f"{command.probe!r} is not an answer offered ({', '.join(choices)})")
            run.answer_probe(command.probe, now)
        else:
            assert command.questionnaire is not None and command.answers is not None
            answers = [int(a) if command.questionnaire == "sus" and a == int(a) else a for a in command.answers]
            run.answer(command.questionnaire, answers, now)
        self._changed(run)

    # -- the relay's events ---------------------------------------------------------------------------------------

    def tick(self, now: float) -> None:
        """Time passes: the task's success, its limit and its probes are judged on the fleet as it is now."""
        run = self.run
        if run is None or run.state.phase != "task":
            return
        poses = self.fleet.positions(now)
        modes = {name: self.fleet.status(name, now)["mode"] for name in self.robots}
        grid = self.map_grid()
        radii = dict.fromkeys(self.robots, ROBOT_RADIUS)
        outcome = run.tick(now, poses, modes, radii, grid.clearance if grid is not None else None, self._truth)
        if outcome is not None:
            if outcome in ("success", "limit"):
                logger.info("study: %s's task ended: %s after %.2f s", run.state.participant, outcome, run.elapsed)
            self._changed(run)

    def _truth(self, probe: Probe) -> str:
        now = self.clock()
        return truth(probe, self.fleet.positions(now), self.fleet.status(probe.robot, now)["mode"], self.rooms())

    def _choices(self, probe: Probe) -> list[str]:
        return choices(probe, self.robots, self.rooms())

    async def _ticker(self) -> None:
        while True:
            await asyncio.sleep(TICK)
            try:
                self.tick(self.clock())
            except Exception:
                logger.exception("study: a tick failed; the run goes on at the next")

    def _save(self, run: StudyRun, active: bool = False) -> None:
        if self.writer is not None:
            self.writer.put(run.state.participant, run.saved(), active=active)


def check_robots(study: Study, robots: Sequence[str], file: str) -> None:
    """Every robot the study names (start poses, successes, probes) is one of the fleet's: ConfigError otherwise."""
    for i, task in enumerate(study.tasks):
        named = [(f"tasks[{i}].start.robots.{p.robot}", p.robot) for p in task.start.poses]
        named += [(f"tasks[{i}].probes[{n}].robot", p.robot) for n, p in enumerate(task.probes)]
        if isinstance(task.success, RobotInRegion | GoalReached):
            kind = "robot_in_region" if isinstance(task.success, RobotInRegion) else "goal_reached"
            named.append((f"tasks[{i}].success.{kind}.robot", task.success.robot))
        for field, robot in named:
            if robot not in robots:
                raise ConfigError(file, None, field, f'"{robot}" is not a robot of the fleet ({", ".join(robots)})')
