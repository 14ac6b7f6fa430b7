"""A study's results as tidy rows (one per participant, condition, task and measure) and their summary per
condition: mean, standard deviation (n - 1) and median of each measure.

Measures taken per task (time to success, commands, refusals, near-collisions, estops, teleop and goal time, view
switches, probe answers, the TLX) carry their task; those taken per condition (the SUS) carry none.
"""

from __future__ import annotations

import csv
import io
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

#: The CSV's columns, in order.
COLUMNS = ("study", "participant", "condition", "task", "measure", "value")


@dataclass(frozen=True, slots=True)
class Row:
    study: str
    participant: str
    condition: str
    task: str  # "" for a measure of the whole condition (the SUS)
    measure: str
    value: float


@dataclass(frozen=True, slots=True)
class Summary:
    condition: str
    measure: str
    n: int
    mean: float
    sd: float | None  # None with one value
    median: float
    values: tuple[float, ...]


def tidy_csv(rows: Iterable[Row]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in rows:
        writer.writerow((r.study, r.participant, r.condition, r.task, r.measure, repr(r.value)))
    return out.getvalue()


def summarise(rows: Sequence[Row], conditions: Sequence[str]) -> list[Summary]:
    """Per measure, then per condition in the study's order: the values over participants (and tasks)."""
    measures = list(dict.fromkeys(r.measure for r in rows))
    out: list[Summary] = []
    for measure in measures:
        for condition in conditions:
            values = tuple(r.value for r in rows if r.measure == measure and r.condition == condition)
            if not values:
                continue
            sd = statistics.stdev(values) if len(values) > 1 else None
            out.append(
                Summary(
                    condition, measure, len(values), statistics.fmean(values), sd, statistics.median(values), values
                )
            )
    return out
