"""One participant's run through a study: the conditions in their order, each condition's tasks, the questionnaires
after each task and condition, and the measures each gives (relay.study.results.Row). Pure: time, the robots'
poses and modes, and the relay's truth for a probe are passed in; nothing here waits or reads a clock.

A task starts when the participant (or the experimenter) says so, after its instruction is shown; it ends on its
success or its time limit. A probe freezes the task: its clock stops until the answer. A run is saved as JSON after
every change (relay.study.store); a task interrupted by a restart of the relay starts again from its instruction,
counted in its ``restarts`` measure, because its robots were not where it left them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from .model import Probe, Questionnaire, Study, Task
from .results import Row
from .rules import Clearance, contacts, succeeded
from .scores import sus_score, tlx_raw

Phase = Literal["ready", "task", "probe", "questions", "done"]
#: Robot modes (the fleet's status) that count as driving by hand and as following a goal.
TELEOP_MODES = frozenset({"teleop"})
GOAL_MODES = frozenset({"navigating"})


class StudyError(ValueError):
    """A step the run is not at (an answer with no question asked, a start during a task): the message says why."""


@dataclass
class Counters:
    """What a task measures while it runs."""

    commands: int = 0
    refusals: int = 0
    estops: int = 0
    view_switches: int = 0
    near_collisions: int = 0
    teleop_s: float = 0.0
    goal_s: float = 0.0
    probes_right: int = 0
    probes_asked: int = 0
    findings: list[str] = field(default_factory=list)
    goals_reached: list[str] = field(default_factory=list)


@dataclass
class RunState:
    """What is saved: where the run is and what it has measured."""

    participant: str
    condition: int = 0
    task: int = 0
    phase: Phase = "ready"
    pending: list[Questionnaire] = field(default_factory=list)  # questionnaires still to answer now
    asking: Literal["task", "condition"] = "task"  # what the questionnaires now asked are about
    restarts: int = 0  # of the current task
    rows: list[dict[str, Any]] = field(default_factory=list)


class StudyRun:
    def __init__(self, study: Study, state: RunState) -> None:
        if state.participant not in study.participants:
            raise StudyError(f"{state.participant!r} is not a participant of {study.name}")
        self.study = study
        self.state = state
        self.counters = Counters()
        self.elapsed = 0.0  # task time, probes excluded
        self.last_tick: float | None = None
        self.asked: float | None = None  # when the questions or the probe now shown were asked
        self.probe: tuple[Probe, str] | None = None  # the probe asked and the relay's answer at that moment
        self.near_now: frozenset[tuple[str, str]] = frozenset()

    @classmethod
    def restored(cls, study: Study, saved: Mapping[str, Any]) -> StudyRun:
        """A run saved before the relay stopped; a task it was in starts again from its instruction."""
        state = RunState(**saved)
        if state.phase in ("task", "probe"):
            state.phase = "ready"
            state.restarts += 1
        return cls(study, state)

    def saved(self) -> dict[str, Any]:
        return asdict(self.state)

    # -- where the run is -----------------------------------------------------------------------------------------

    @property
    def condition(self) -> str:
        return self.study.order(self.state.participant)[self.state.condition]

    @property
    def task(self) -> Task:
        return self.study.tasks[self.state.task]

    @property
    def settings(self) -> dict[str, str]:
        """The page settings of the current condition."""
        return dict(next(c.client for c in self.study.conditions if c.name == self.condition))

    # -- a task ---------------------------------------------------------------------------------------------------

    def begin(self, now: float) -> Task:
        if self.state.phase != "ready":
            raise StudyError(f"a task starts from its instruction; the run is at {self.state.phase}")
        self.state.phase = "task"
        self.counters = Counters()
        self.elapsed = 0.0
        self.last_tick = now
        self.near_now = frozenset()
        return self.task

    def command(self, refused: bool) -> None:
        if self.state.phase == "task":
            self.counters.commands += 1
            self.counters.refusals += refused

    def estop(self) -> None:
        if self.state.phase == "task":
            self.counters.estops += 1

    def view_switch(self) -> None:
        if self.state.phase == "task":
            self.counters.view_switches += 1

    def finding(self, target: str) -> None:
        if self.state.phase == "task":
            self.counters.findings.append(target)

    def goal_reached(self, robot: str) -> None:
        if self.state.phase == "task":
            self.counters.goals_reached.append(robot)

    def tick(
        self,
        now: float,
        poses: Mapping[str, tuple[float, float]],
        modes: Mapping[str, str],
        radii: Mapping[str, float],
        clearance: Clearance | None,
        truth: Callable[[Probe], str],
    ) -> Probe | Literal["success", "limit"] | None:
        """Time passes in a task: returns a probe to ask now, the task's end, or None."""
        if self.state.phase != "task" or self.last_tick is None:
            return None
        dt = max(0.0, now - self.last_tick)
        self.last_tick = now
        self.elapsed += dt
        c = self.counters
        if any(m in TELEOP_MODES for m in modes.values()):
            c.teleop_s += dt
        if any(m in GOAL_MODES for m in modes.values()):
            c.goal_s += dt
        close = contacts(poses, radii, clearance)
        c.near_collisions += len(close - self.near_now)  # counted as robots come close, not while they stay
        self.near_now = close
        if succeeded(self.task.success, poses, frozenset(c.findings), frozenset(c.goals_reached), c.near_collisions):
            self._end(True, now)
            return "success"
        if self.elapsed >= self.task.time_limit:
            self.elapsed = self.task.time_limit
            self._end(False, now)
            return "limit"
        due = [p for p in self.task.probes if p.at <= self.elapsed][c.probes_asked :]
        if due:
            c.probes_asked += 1
            self.probe = (due[0], truth(due[0]))
            self.state.phase = "probe"
            self.asked = now
            return due[0]
        return None

    def answer_probe(self, answer: str, now: float) -> bool:
        """The participant's answer to the probe asked; the task goes on. Returns whether it was right."""
        if self.state.phase != "probe" or self.probe is None:
            raise StudyError("no probe is asked now")
        probe, truth = self.probe
        right = answer == truth
        self.counters.probes_right += right
        self._row(self.task.name, f"probe_{probe.question}_s", now - (self.asked or now))
        self.probe = None
        self.state.phase = "task"
        self.last_tick = now  # the frozen time is not the task's
        return right

    def _end(self, success: bool, now: float) -> None:
        c, name = self.counters, self.task.name
        measures: dict[str, float] = {
            "time_s": self.elapsed,
            "success": float(success),
            "commands": c.commands,
            "refusals": c.refusals,
            "estops": c.estops,
            "view_switches": c.view_switches,
            "near_collisions": c.near_collisions,
            "teleop_s": c.teleop_s,
            "goal_s": c.goal_s,
            "restarts": self.state.restarts,
        }
        if c.probes_asked:
            measures["probe_correct"] = c.probes_right / c.probes_asked
        for measure, value in measures.items():
            self._row(name, measure, float(value))
        self.state.restarts = 0
        self._ask(list(self.study.after_task), "task", now) if self.study.after_task else self._next_task(now)

    # -- questionnaires -------------------------------------------------------------------------------------------

    def answer(self, questionnaire: Questionnaire, answers: list[Any], now: float) -> float:
        """Answers to the questionnaire asked now: scored (raises AnswerError naming a bad one), the run goes on."""
        if self.state.phase != "questions" or not self.state.pending or self.state.pending[0] != questionnaire:
            asked = self.state.pending[0] if self.state.phase == "questions" and self.state.pending else "nothing"
            raise StudyError(f"{questionnaire} is not asked now ({asked} is)")
        score = sus_score(answers) if questionnaire == "sus" else tlx_raw(answers)
        about = self.task.name if self.state.asking == "task" else ""
        self._row(about, questionnaire, score)
        self._row(about, f"{questionnaire}_s", now - (self.asked or now))
        self.state.pending.pop(0)
        self.asked = now
        if not self.state.pending:
            self._next_task(now) if self.state.asking == "task" else self._next_condition()
        return score

    def _ask(self, questionnaires: list[Questionnaire], about: Literal["task", "condition"], now: float) -> None:
        self.state.pending = questionnaires
        self.state.asking = about
        self.state.phase = "questions"
        self.asked = now

    def _next_task(self, now: float) -> None:
        if self.state.task + 1 < len(self.study.tasks):
            self.state.task += 1
            self.state.phase = "ready"
        elif self.study.after_condition:
            self._ask(list(self.study.after_condition), "condition", now)
        else:
            self._next_condition()

    def _next_condition(self) -> None:
        self.state.task = 0
        if self.state.condition + 1 < len(self.study.conditions):
            self.state.condition += 1
            self.state.phase = "ready"
        else:
            self.state.phase = "done"

    def _row(self, task: str, measure: str, value: float) -> None:
        row = Row(self.study.name, self.state.participant, self.condition, task, measure, value)
        self.state.rows.append(asdict(row))

    def rows(self) -> list[Row]:
        return [Row(**r) for r in self.state.rows]
