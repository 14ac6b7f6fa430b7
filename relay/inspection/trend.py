"""A target's readings over its last rounds, and whether one trends toward its limit. Pure: captures and limits in,
numbers and words out; every time is passed in (the captures' own), nothing here reads a clock or the database.

A round is a mission's capture of the target (relay.inspection.store.Store.captures_of reads the last ones). The
threshold rule (relay.inspection.captures) already makes an ``anomaly`` of a reading past its limit; this rule
catches the reading still inside its limit that is getting there: the place should be looked at before it does.
"""

from __future__ import annotations

import itertools
import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Final, Literal, Protocol

from .records import CaptureRecord, ReadingTrend

#: How many rounds a trend looks back: ten rounds show a drift (a daily round: a week and a half) while an old
#: state of the place (before a repair) soon stops weighing on the slope.
TREND_ROUNDS: Final = 10
#: Fewest readings a slope is drawn from: two points always make a line, a third is the first that can disagree.
MIN_READINGS: Final = 3
#: How many rounds ahead a projected crossing makes a finding: the next few rounds, the time a work order of medium
#: priority gives (a week, report_rows.DUE_AFTER, at a round a day or more often); a crossing projected further
#: out is a guess over readings that still have time to level off, and would cry wolf.
HORIZON_ROUNDS: Final = 3


class SensorLimit(Protocol):
    """A sensor's unit and warning thresholds (robots.yaml: relay.config.Sensor, relay.inspection.report_rows.Limit)."""

    @property
    def unit(self) -> str: ...
    @property
    def warn_above(self) -> float | None: ...
    @property
    def warn_below(self) -> float | None: ...


@dataclass(frozen=True)
class Point:
    """One reading of a round: when (Unix s), its value, and the mission (the round) that took it."""

    t: float
    value: float
    mission: str | None


@dataclass(frozen=True)
class Trend:
    """A sensor's readings over the last rounds (oldest first) against its limit.

    ``slope``: the least-squares slope, in the unit per round (a round: the median time between the readings);
    ``limit`` and ``side``: the threshold the readings head for (``above``: warn_above, ``below``: warn_below);
    ``rounds_left``: rounds until the fitted line passes it (0: it is past it already), None when it never does;
    ``toward_limit``: the rule's verdict (``trend_of``)."""

    sensor: str
    unit: str
    points: tuple[Point, ...]
    slope: float | None
    limit: float | None
    side: Literal["above", "below"] | None
    rounds_left: float | None
    toward_limit: bool

    @property
    def latest(self) -> float:
        return self.points[-1].value

    @property
    def previous(self) -> float | None:
        return self.points[-2].value if len(self.points) > 1 else None

    def record(self) -> ReadingTrend:
        """What a finding keeps of it (and its message carries): the times and values, the threshold, the unit."""
        return ReadingTrend(self.sensor, self.unit, self.limit, tuple((p.t, p.value) for p in self.points))

    def words(self) -> str:
        """``gas 204.5, 284.2, 370.9 ppm over the last 3 rounds (+83.2 ppm a round): at that rate over its 400 ppm
        limit within 1 round``: the note of the finding a trend makes."""
        unit = f" {self.unit}" if self.unit else ""
        values = ", ".join(f"{p.value:.1f}" for p in self.points)
        said = f"{self.sensor} {values}{unit} over the last {len(self.points)} rounds"
        if self.slope is None:
            return said
        said += f" ({self.slope:+.1f}{unit} a round)"
        if self.limit is None or self.rounds_left is None:
            return said
        rounds = max(1, math.ceil(self.rounds_left))
        verb = "over its" if self.side == "above" else "under its"
        return f"{said}: at that rate {verb} {self.limit:g}{unit} limit within {rounds} round{'s' * (rounds != 1)}"


def series_of(captures: Sequence[CaptureRecord], sensor: str) -> tuple[Point, ...]:
    """The sensor's readings in ``captures`` (oldest first, as Store.captures_of gives them), the last
    ``TREND_ROUNDS``; captures without that sensor are left out."""
    points = [Point(c.t, c.readings[sensor], c.mission) for c in captures if sensor in c.readings]
    return tuple(p for p in points if math.isfinite(p.value))[-TREND_ROUNDS:]


def fit(points: Sequence[Point]) -> tuple[float, float] | None:
    """The least-squares line of the values over time: its slope in the unit a round (a round: the median of the
    gaps between the readings, so that one late round does not stretch every other) and its value at the latest
    reading. None under ``MIN_READINGS`` readings, or when they are all at one time."""
    if len(points) < MIN_READINGS:
        return None
    ts = [p.t - points[-1].t for p in points]  # relative: Unix seconds squared lose the digits that matter
    mean_t, mean_v = statistics.fmean(ts), statistics.fmean(p.value for p in points)
    spread = sum((t - mean_t) ** 2 for t in ts)
    gap = statistics.median(b - a for a, b in itertools.pairwise(ts))
    if spread <= 0 or gap <= 0:
        return None
    per_second = sum((t - mean_t) * (p.value - mean_v) for t, p in zip(ts, points, strict=True)) / spread
    return per_second * gap, mean_v - per_second * mean_t  # the latest reading is at t = 0


def trend_of(sensor: str, points: Sequence[Point], limit: SensorLimit) -> Trend:
    """The trend of ``points`` (oldest first) against the sensor's limit.

    It **trends toward its limit** when, over at least ``MIN_READINGS`` readings, the least-squares line heads for a
    threshold the latest reading has not passed and reaches it within ``HORIZON_ROUNDS`` rounds of the latest. A
    reading past its limit is not a trend finding: the threshold rule has made it an anomaly already. A line fitted
    to all the last readings, not the last two: one noisy reading does not make a trend, and one flat reading does
    not hide one."""
    points = tuple(points)
    line = fit(points)
    slope = None if line is None else line[0]
    side: Literal["above", "below"] | None = None
    bound = None
    if limit.warn_above is not None and (slope is None or slope >= 0 or limit.warn_below is None):
        side, bound = "above", limit.warn_above
    elif limit.warn_below is not None:
        side, bound = "below", limit.warn_below
    rounds_left = None
    toward = False
    if line is not None and bound is not None:
        slope, fitted = line
        latest = points[-1].value
        inside = latest <= bound if side == "above" else latest >= bound
        if (slope > 0 and side == "above") or (slope < 0 and side == "below"):
            rounds_left = max(0.0, (bound - fitted) / slope)
            toward = inside and rounds_left <= HORIZON_ROUNDS
    return Trend(sensor, limit.unit, points, slope, bound, side, rounds_left, toward)


def concern(trends: Sequence[Trend]) -> Trend | None:
    """The trend a finding's card shows when the finding names none: one toward its limit first, then the reading
    nearest its limit (the latest value as a share of the way to it), else the first."""
    if not trends:
        return None

    def nearness(trend: Trend) -> float:
        if not trend.points or trend.limit is None or trend.limit == 0 or trend.latest == 0:
            return -math.inf
        return trend.latest / trend.limit if trend.side == "above" else trend.limit / trend.latest

    return max(trends, key=lambda t: (t.toward_limit, nearness(t)))
