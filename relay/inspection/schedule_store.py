"""The schedules table and the record of each run (relay.inspection.scheduler keeps them; ``xr-relay schedule``
changes them from the command line).

A part of the store (relay.inspection.store's ``Store`` is one): the same connection, transactions and errors
(relay.inspection.database). A schedule's mission, windows and blackouts are JSON in TEXT columns, as steps are.
Removing a schedule removes it and its runs in one transaction.
"""

from __future__ import annotations

import json
from dataclasses import fields
from typing import Any

from .alert_store import AlertTables
from .records import ScheduleRecord, ScheduleRun
from .rows import columns

_SCHEDULE = columns(ScheduleRecord)
_RUN = columns(ScheduleRun)
_JSON = ("mission", "windows", "blackouts")


def schedule_row(schedule: ScheduleRecord) -> tuple[Any, ...]:
    return tuple(
        json.dumps(getattr(schedule, f.name)) if f.name in _JSON else getattr(schedule, f.name)
        for f in fields(ScheduleRecord)
    )


def schedule_of(row: tuple[Any, ...]) -> ScheduleRecord:
    data = dict(zip((f.name for f in fields(ScheduleRecord)), row, strict=True))
    data["mission"] = json.loads(data["mission"])
    data["windows"] = tuple((tuple(days), int(first), int(last)) for days, first, last in json.loads(data["windows"]))
    data["blackouts"] = tuple((float(a), float(b)) for a, b in json.loads(data["blackouts"]))
    data["priority"] = int(data["priority"])
    return ScheduleRecord(**data)


class ScheduleTables(AlertTables):
    """Schedules and their runs in the inspection database."""

    def save_schedule(self, schedule: ScheduleRecord) -> None:
        """Insert the schedule, or replace the one of its name (every field)."""
        values = schedule_row(schedule)
        updates = ", ".join(f"{c} = excluded.{c}" for c in _SCHEDULE.split(", ")[1:])
        self._write(
            f"INSERT INTO schedules ({_SCHEDULE}) VALUES ({', '.join('?' * len(values))}) "
            f"ON CONFLICT (id) DO UPDATE SET {updates}",
            values,
        )

    def add_schedule(self, schedule: ScheduleRecord) -> bool:
        """Insert a new schedule; False (and nothing changed) when one of its name exists."""
        values = schedule_row(schedule)
        rows = self._write(
            f"INSERT INTO schedules ({_SCHEDULE}) VALUES ({', '.join('?' * len(values))}) "
            "ON CONFLICT (id) DO NOTHING RETURNING id",
            values,
        )
        return bool(rows)

    def remove_schedule(self, name: str) -> bool:
        """Remove a schedule and its runs; False when there is none of that name."""
        with self._transaction() as cursor:
            cursor.execute(self._sql("DELETE FROM schedule_runs WHERE schedule = ?"), (name,))
            cursor.execute(self._sql("DELETE FROM schedules WHERE id = ? RETURNING id"), (name,))
            return bool(cursor.fetchall())

    def schedule(self, name: str) -> ScheduleRecord | None:
        rows = self._read(f"SELECT {_SCHEDULE} FROM schedules WHERE id = ?", (name,))
        return schedule_of(rows[0]) if rows else None

    def schedules(self) -> list[ScheduleRecord]:
        """Every schedule, by name."""
        return [schedule_of(r) for r in self._read(f"SELECT {_SCHEDULE} FROM schedules ORDER BY id")]

    # -- runs -------------------------------------------------------------------------------------

    def add_schedule_run(self, run: ScheduleRun) -> None:
        values = tuple(getattr(run, f.name) for f in fields(ScheduleRun))
        self._write(f"INSERT INTO schedule_runs ({_RUN}) VALUES ({', '.join('?' * len(values))})", values)

    def schedule_runs(self, name: str, limit: int = 100) -> list[ScheduleRun]:
        """The newest ``limit`` runs of a schedule, newest first."""
        rows = self._read(
            f"SELECT {_RUN} FROM schedule_runs WHERE schedule = ? ORDER BY slot DESC, t DESC, id DESC LIMIT ?",
            (name, limit),
        )
        return [ScheduleRun(*r) for r in rows]

    def last_schedule_runs(self) -> dict[str, ScheduleRun]:
        """Each schedule's latest run (by slot): where a restarted relay takes up its schedules."""
        rows = self._read(
            f"SELECT {', '.join('r.' + c for c in _RUN.split(', '))} FROM schedule_runs r JOIN "
            "(SELECT schedule, MAX(slot) AS slot FROM schedule_runs GROUP BY schedule) m "
            "ON m.schedule = r.schedule AND m.slot = r.slot ORDER BY r.t, r.id"
        )
        return {run.schedule: run for run in (ScheduleRun(*r) for r in rows)}
