"""Records as database rows: a record's fields are its table's columns, in order (relay.inspection.store)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, fields
from typing import Any, TypeVar

from .records import (
    AlertRecord,
    CaptureRecord,
    DeliveryRecord,
    FindingRecord,
    MissionRecord,
    ReadingTrend,
    Step,
    Target,
)

_R = TypeVar("_R", MissionRecord, CaptureRecord, FindingRecord, Target, AlertRecord, DeliveryRecord)
Record = MissionRecord | CaptureRecord | FindingRecord | Target | AlertRecord | DeliveryRecord


def columns(record: type[Any]) -> str:
    """The columns of a record's table are its fields, in order: a field without a column fails every insert."""
    return ", ".join(f.name for f in fields(record))


def row_of(record: Record) -> tuple[Any, ...]:
    """The row of a record: its fields in order, steps, readings, region and trend as JSON text."""
    values: list[Any] = []
    for f in fields(record):
        value = getattr(record, f.name)
        if f.name == "steps":
            value = json.dumps([{k: v for k, v in asdict(step).items() if v is not None} for step in value])
        elif f.name in ("readings", "region") and value is not None:
            value = json.dumps(value)
        elif f.name == "trend" and value is not None:
            value = json.dumps(asdict(value))
        values.append(value)
    return tuple(values)


def record_of(kind: type[_R], row: Sequence[Any]) -> _R:
    """The record of a row: the inverse of ``row_of``."""
    data = dict(zip((f.name for f in fields(kind)), row, strict=True))
    if "steps" in data:
        data["steps"] = tuple(Step(**step) for step in json.loads(data["steps"]))
    if "readings" in data:
        data["readings"] = json.loads(data["readings"])
    if data.get("region") is not None:
        data["region"] = tuple((int(u), int(v)) for u, v in json.loads(data["region"]))
    if data.get("trend") is not None:
        trend = json.loads(data["trend"])
        points = tuple((float(t), float(v)) for t, v in trend["points"])
        data["trend"] = ReadingTrend(trend["sensor"], trend["unit"], trend["threshold"], points)
    return kind(**data)
