"""A reading's trend as a sparkline for the report: its last rounds' values scaled into a small box, with its
threshold as a level across it. Pure geometry, the same as the client's (xr_client/src/sparkline.js draws the
desktop card's): time left to right over the rounds' span, values bottom to top over their range widened to hold
the threshold (so its line is always in view and a reading's distance to it reads true), 10 % of margin."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final


@dataclass(frozen=True)
class Box:
    width: float
    height: float
    pad: float


#: Wide enough for ten rounds, as tall as two lines of text (SVG user units; the client's SPARK_BOX).
SPARK_BOX: Final = Box(160.0, 40.0, 4.0)


@dataclass(frozen=True)
class Sparkline:
    """``points``: (x, y) of each reading, oldest first; ``limit``: the threshold's y (None: none)."""

    points: tuple[tuple[float, float], ...]
    limit: float | None
    low: float
    high: float


def sparkline(points: Sequence[tuple[float, float]], threshold: float | None, box: Box = SPARK_BOX) -> Sparkline:
    """The readings ``points`` ((time, value), oldest first) in ``box``; one reading sits in the middle, a flat series
    gets a band of 5 % of its value (else 1) each way."""
    finite = [(t, v) for t, v in points if math.isfinite(v)]
    values = [v for _, v in finite] + ([] if threshold is None else [threshold])
    if not values:
        return Sparkline((), None, 0.0, 0.0)
    low, high = min(values), max(values)
    margin = (high - low) * 0.1 if high > low else abs(high) * 0.05 or 1.0
    low, high = low - margin, high + margin
    first = finite[0][0] if finite else 0.0
    span = finite[-1][0] - first if finite else 0.0
    inner_w, inner_h = box.width - 2 * box.pad, box.height - 2 * box.pad

    def y(value: float) -> float:
        return box.pad + (high - value) / (high - low) * inner_h

    xy = tuple(
        (box.pad + ((t - first) / span * inner_w if span > 0 else inner_w / 2), y(v)) for t, v in finite
    )  # fmt: skip
    return Sparkline(xy, None if threshold is None else y(threshold), low, high)


def label_y(limit: float, box: Box = SPARK_BOX) -> float:
    """Where the threshold's label stands: above its line, or under it when the line runs in the upper half (a
    label above would leave the box)."""
    return limit + 9.0 if limit < box.height / 2 else limit - 2.0


def polyline(points: Sequence[tuple[float, float]]) -> str:
    """An SVG ``points`` attribute of the line through them, to 0.1 unit."""
    return " ".join(f"{_short(x)},{_short(y)}" for x, y in points)


def _short(n: float) -> str:
    return f"{round(n, 1):g}"
