"""A study run on the wire (docs/protocol.md, "Studies"): the commands ``study/join``, ``study/start`` and
``study/answer``, and the relay's ``study`` message, sent to every client on every change of the run.

Declared like every command (relay/wire/declare.py) and gathered in relay/session/protocol.py; what they do is
relay/study/service.py's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Final, Literal, TypedDict

from ..errors import ProtocolError
from ..wire.declare import Forms, Frame, WireCommand, command, custom, request, text
from ..wire.fields import ErrorCode, RequestId, show
from .model import QUESTIONNAIRES, Questionnaire

#: The most answers a questionnaire takes (the SUS's ten items; the TLX has six scales).
MAX_ANSWERS: Final = 10
#: What the run is at: no participant yet (``waiting``), or the run's own phase (relay/study/run.py).
StudyPhase = Literal["waiting", "ready", "task", "probe", "questions", "done"]


@command("study/join")
@dataclass(frozen=True, slots=True)
class StudyJoin(WireCommand):
    """This client is ``participant``'s station: its run (new, or where it was left) becomes the one the relay
    drives, and the answers come from this client."""

    id: RequestId = request()
    participant: str = text()


@command("study/start")
@dataclass(frozen=True, slots=True)
class StudyStart(WireCommand):
    """Start the task whose instruction is shown: its start state applied, its clock started."""

    id: RequestId = request()


def _questionnaire(value: Any, field: str, identifier: str) -> Questionnaire | None:
    if value is not None and value not in QUESTIONNAIRES:
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field '{field}' must be one of {', '.join(QUESTIONNAIRES)}, got {show(value)}",
        )
    return value  # type: ignore[no-any-return]


def _answers(value: Any, field: str, identifier: str) -> tuple[float, ...] | None:
    if value is None:
        return None
    if (
        not isinstance(value, list)
        or not 1 <= len(value) <= MAX_ANSWERS
        or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        raise ProtocolError(
            ErrorCode.BAD_REQUEST,
            f"{identifier}: field '{field}' must be a list of 1 to {MAX_ANSWERS} numbers, got {show(value)}",
        )
    return tuple(value)


@command("study/answer")
@dataclass(frozen=True, slots=True)
class StudyAnswer(WireCommand):
    """The participant's answers to the questionnaire asked now (SUS: ten items 1-5; raw NASA-TLX: six scales
    0-100), or to the probe asked now (one of its choices)."""

    FORMS: ClassVar[Forms] = {
        "StudyQuestionnaireAnswerCommand": (("study/answer",), ("questionnaire", "answers"), ()),
        "StudyProbeAnswerCommand": (("study/answer",), ("probe",), ()),
    }
    id: RequestId = request()
    questionnaire: Questionnaire | None = custom(_questionnaire, "'sus' | 'tlx'")
    answers: tuple[float, ...] | None = custom(_answers, "number[]")
    probe: str | None = text(required=False)

    def check(self, frame: Frame) -> None:
        if (self.probe is None) == (self.questionnaire is None):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: give exactly one of questionnaire, probe")
        if self.questionnaire is not None and self.answers is None:
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: missing field 'answers'")


STUDY_COMMANDS: Final = (StudyJoin, StudyStart, StudyAnswer)
StudyCommand = StudyJoin | StudyStart | StudyAnswer


class StudyProbe(TypedDict):
    """A situation-awareness probe asked now: its question about ``robot``, and the answers offered."""

    question: str
    robot: str
    choices: list[str]


class StudyMessage(TypedDict):
    identifier: Literal["study"]
    study: str
    phase: StudyPhase
    participants: list[str]
    participant: str | None
    #: The condition's name and the page settings under it (view, sound, input).
    condition: str | None
    settings: dict[str, str]
    task: str | None
    instruction: str | None
    time_limit: float | None
    #: Seconds of the task so far (probes excluded) when this was sent; the page counts on from there in a task.
    elapsed: float
    #: The questionnaire asked now (``questions``), or None.
    questionnaire: Questionnaire | None
    probe: StudyProbe | None
    #: Tasks done of all the participant's tasks (conditions times tasks).
    done: int
    total: int


def study_message(
    *,
    study: str,
    phase: StudyPhase,
    participants: list[str],
    participant: str | None = None,
    condition: str | None = None,
    settings: dict[str, str] | None = None,
    task: str | None = None,
    instruction: str | None = None,
    time_limit: float | None = None,
    elapsed: float = 0.0,
    questionnaire: Questionnaire | None = None,
    probe: StudyProbe | None = None,
    done: int = 0,
    total: int = 0,
) -> StudyMessage:
    return {
        "identifier": "study",
        "study": study,
        "phase": phase,
        "participants": participants,
        "participant": participant,
        "condition": condition,
        "settings": settings or {},
        "task": task,
        "instruction": instruction,
        "time_limit": time_limit,
        "elapsed": round(elapsed, 3),
        "questionnaire": questionnaire,
        "probe": probe,
        "done": done,
        "total": total,
    }
