"""What a study file says (relay.study.study_file reads it): who takes part, under which conditions in which order,
the tasks with their start states and the success the relay detects, and the questionnaires asked.

A condition is a set of the page's settings (the view, sound, the input): the participant's page applies them when
the condition starts, and the relay records which condition every measure was taken under.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final, Literal

#: The page settings a condition may set, and the values each takes.
CLIENT_SETTINGS: Final[dict[str, tuple[str, ...]]] = {
    "view": ("desktop", "headset"),
    "sound": ("on", "off"),
    "input": ("controllers", "hands"),
}
#: The questionnaires: the System Usability Scale (10 items, 1-5) and the raw NASA-TLX (6 scales, 0-100).
Questionnaire = Literal["sus", "tlx"]
QUESTIONNAIRES: Final[tuple[Questionnaire, ...]] = ("sus", "tlx")
#: What a situation-awareness probe asks about a robot, scored against the relay's own state at that moment.
ProbeQuestion = Literal["room", "mode", "nearest_robot"]
PROBE_QUESTIONS: Final[tuple[ProbeQuestion, ...]] = ("room", "mode", "nearest_robot")


@dataclass(frozen=True, slots=True)
class Condition:
    name: str
    client: tuple[tuple[str, str], ...]  # (setting, value), as CLIENT_SETTINGS allows


@dataclass(frozen=True, slots=True)
class StartPose:
    robot: str
    x: float
    y: float
    yaw: float


@dataclass(frozen=True, slots=True)
class Start:
    """The state a task starts from: robots placed (the simulated fleet), the estop reset, goals cancelled."""

    poses: tuple[StartPose, ...] = ()
    reset_estop: bool = True


@dataclass(frozen=True, slots=True)
class RobotInRegion:
    """Success: the robot is inside the polygon (map metres)."""

    robot: str
    region: tuple[tuple[float, float], ...]


@dataclass(frozen=True, slots=True)
class FindingAtTarget:
    """Success: a finding is marked at the named inspection target."""

    target: str


@dataclass(frozen=True, slots=True)
class GoalReached:
    """Success: the robot reached a goal; with ``without_collision``, only if no near-collision happened in the
    task."""

    robot: str
    without_collision: bool = False


Success = RobotInRegion | FindingAtTarget | GoalReached


@dataclass(frozen=True, slots=True)
class Probe:
    """A situation-awareness probe: ``at`` seconds into the task the scene freezes and the question is asked."""

    at: float
    question: ProbeQuestion
    robot: str


@dataclass(frozen=True, slots=True)
class Task:
    name: str
    instruction: str
    time_limit: float  # seconds
    start: Start
    success: Success
    probes: tuple[Probe, ...] = ()


@dataclass(frozen=True, slots=True)
class Study:
    name: str
    participants: tuple[str, ...]
    conditions: tuple[Condition, ...]
    orders: tuple[tuple[str, tuple[str, ...]], ...]  # each participant's conditions, in the order they do them
    tasks: tuple[Task, ...]
    after_task: tuple[Questionnaire, ...] = ("tlx",)
    after_condition: tuple[Questionnaire, ...] = ("sus",)

    def order(self, participant: str) -> tuple[str, ...]:
        return dict(self.orders)[participant]
