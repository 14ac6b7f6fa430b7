"""Questionnaire scores by their standard formulas.

SUS (Brooke, 1996): ten items answered 1-5; odd items (positively worded) give answer - 1, even items 5 - answer; the
sum times 2.5 is the score, 0-100. Raw NASA-TLX (Hart, 2006): six scales answered 0-100 (mental, physical and
temporal demand, performance, effort, frustration); the raw score is their mean, no pairwise weights.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final

SUS_ITEMS: Final = 10
TLX_SCALES: Final = ("mental", "physical", "temporal", "performance", "effort", "frustration")


class AnswerError(ValueError):
    """Answers that do not fit the questionnaire: the message names which."""


def sus_score(answers: Sequence[int]) -> float:
    if len(answers) != SUS_ITEMS:
        raise AnswerError(f"SUS has {SUS_ITEMS} items, got {len(answers)} answers")
    for i, a in enumerate(answers, 1):
        if isinstance(a, bool) or not isinstance(a, int) or not 1 <= a <= 5:
            raise AnswerError(f"SUS item {i}: expected 1-5, got {a!r}")
    return 2.5 * sum(a - 1 if i % 2 == 1 else 5 - a for i, a in enumerate(answers, 1))


def tlx_raw(answers: Sequence[float]) -> float:
    if len(answers) != len(TLX_SCALES):
        raise AnswerError(f"NASA-TLX has {len(TLX_SCALES)} scales, got {len(answers)} answers")
    for scale, a in zip(TLX_SCALES, answers, strict=True):
        if isinstance(a, bool) or not isinstance(a, int | float) or not 0 <= a <= 100:
            raise AnswerError(f"NASA-TLX {scale}: expected 0-100, got {a!r}")
    return sum(answers) / len(TLX_SCALES)
