"""Where missions, captures and findings are kept: a SQLite file by default, PostgreSQL when given a URL.

**One SQL layer, plain DB-API, no ORM.** ``sqlite3`` from the standard library; ``psycopg`` 3 for PostgreSQL,
imported only when a ``postgresql://`` URL is given. The store is a handful of inserts, one upsert, one update and
filtered selects over three tables whose rows are the frozen dataclasses of ``records.py``: an ORM would add a
second model of the same rows and a dependency the relay would carry even on SQLite, and it costs time. Measured
on this 2-core machine (a throwaway script: this store against a SQLAlchemy 2.1 declarative model of the same
``findings`` table), 1000 findings inserted one transaction each, as the relay inserts them, median of 3 runs:

==========================================  ==========  ===================
1000 findings, one commit each              this store  SQLAlchemy 2.1 ORM
==========================================  ==========  ===================
SQLite 3.40, WAL, ``synchronous=FULL``        0.27 s        0.57 s
SQLite 3.40, WAL, ``synchronous=NORMAL``      0.04 s        0.26 s
PostgreSQL 15 on 127.0.0.1, fsync on          0.36 s        0.83 s
reading the 1000 back (either database)       8 ms          14-15 ms
==========================================  ==========  ===================

The ORM adds 0.2-0.5 ms a row and 0.23 s of import (``sqlite3``: 3 ms). SQLite keeps ``synchronous=FULL``, its
default: 0.27 ms a finding is nothing at a capture every few seconds, and a finding an operator was shown must
survive the station losing power, which ``NORMAL`` does not promise.

The SQL layer (dialects, transactions, migrations, errors) is relay/inspection/database.py; capture images are files
beside the database (relay/inspection/images.py); alerts are relay/inspection/alert_store.py's.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import fields, replace
from pathlib import Path

from .database import StoreError as StoreError  # re-exported: what callers catch
from .images import ImageFiles
from .records import FINDING_STATUSES, CaptureRecord, FindingRecord, MissionRecord, Target
from .rows import columns, record_of, row_of
from .schedule_store import ScheduleTables
from .schema import MIGRATIONS as MIGRATIONS  # re-exported: a test adds a migration to the store's

_MISSION, _CAPTURE, _FINDING, _TARGET = (
    columns(MissionRecord),
    columns(CaptureRecord),
    columns(FindingRecord),
    columns(Target),
)


class UnknownRecord(StoreError, LookupError):
    """No record has that id (a LookupError, as a missing key is)."""


class Store(ScheduleTables):
    """Missions, captures, findings, alerts (relay.inspection.alert_store) and schedules
    (relay.inspection.schedule_store) in one database. Not thread-safe: the relay calls it from one thread."""

    def __init__(self, url: str, images: Path, busy_timeout: float) -> None:
        super().__init__(url, busy_timeout)
        self.images = images
        self._files = ImageFiles(images, self.name)

    @classmethod
    def open(cls, url: str, images: Path, *, busy_timeout: float = 5.0) -> Store:
        """A SQLite file (created, with its directories) or a ``postgresql://`` URL, migrated to this code's schema.

        ``busy_timeout`` (seconds) is how long a write waits for a lock another process holds, and on PostgreSQL
        also how long connecting may take, before ``StoreError``.
        """
        store = cls(url, Path(images), busy_timeout)
        try:
            store.images.mkdir(parents=True, exist_ok=True)
            store._db = store._connect()
            store._migrate(MIGRATIONS)  # read when called, so a test can add a migration
        except OSError as exc:
            store.close()
            raise StoreError(f"database {store.name}: images directory {images}: {exc.strerror or exc}") from exc
        except BaseException:
            store.close()
            raise
        return store

    # -- missions ---------------------------------------------------------------------------------

    def save_mission(self, mission: MissionRecord) -> None:
        """Insert the mission, or replace the one with its id (every field: the record is the truth)."""
        values = row_of(mission)
        updates = ", ".join(f"{c} = excluded.{c}" for c in _MISSION.split(", ")[1:])
        marks = ", ".join("?" * len(values))
        self._write(
            f"INSERT INTO missions ({_MISSION}) VALUES ({marks}) ON CONFLICT (id) DO UPDATE SET {updates}", values
        )

    def mission(self, mission_id: str) -> MissionRecord | None:
        rows = self._read(f"SELECT {_MISSION} FROM missions WHERE id = ?", (mission_id,))
        return record_of(MissionRecord, rows[0]) if rows else None

    def missions(self, limit: int | None = None) -> list[MissionRecord]:
        """Newest first; the newest ``limit`` when given."""
        sql = f"SELECT {_MISSION} FROM missions ORDER BY created DESC, id" + (" LIMIT ?" if limit is not None else "")
        return [record_of(MissionRecord, r) for r in self._read(sql, () if limit is None else (limit,))]

    # -- targets ----------------------------------------------------------------------------------

    def save_targets(self, targets: Sequence[Target]) -> None:
        """Insert the targets, or replace those with their ids; all in one transaction."""
        updates = ", ".join(f"{c} = excluded.{c}" for c in _TARGET.split(", ")[1:])
        sql = self._sql(
            f"INSERT INTO targets ({_TARGET}) VALUES ({', '.join('?' * len(fields(Target)))}) "
            f"ON CONFLICT (id) DO UPDATE SET {updates}"
        )
        with self._transaction() as cursor:
            cursor.executemany(sql, [row_of(t) for t in targets])

    def targets(self) -> list[Target]:
        return [record_of(Target, r) for r in self._read(f"SELECT {_TARGET} FROM targets ORDER BY id")]

    # -- captures and images ----------------------------------------------------------------------

    def add_capture(self, capture: CaptureRecord, jpeg: bytes | None) -> CaptureRecord:
        """Keep the capture and its image (if any); the record as stored, ``image`` the JPEG's SHA-256 or None."""
        stored = replace(capture, image=None if jpeg is None else self._files.keep(jpeg))
        values = row_of(stored)
        self._write(f"INSERT INTO captures ({_CAPTURE}) VALUES ({', '.join('?' * len(values))})", values)
        return stored

    def image(self, sha256: str) -> bytes | None:
        """The JPEG of that SHA-256 (64 lowercase hex digits, nothing else: no path), or None."""
        return self._files.read(sha256)

    def capture(self, capture_id: str) -> CaptureRecord | None:
        rows = self._read(f"SELECT {_CAPTURE} FROM captures WHERE id = ?", (capture_id,))
        return record_of(CaptureRecord, rows[0]) if rows else None

    def captures(self, mission_id: str | None = None) -> list[CaptureRecord]:
        """Oldest first; those of one mission, or all."""
        where, args = ("WHERE mission = ?", (mission_id,)) if mission_id is not None else ("", ())
        return [
            record_of(CaptureRecord, r)
            for r in self._read(f"SELECT {_CAPTURE} FROM captures {where} ORDER BY t, id", args)
        ]

    def last_capture_of(self, target: str, before: float, but: str) -> CaptureRecord | None:
        """The newest capture of ``target`` with an image taken before ``before`` (Unix s), other than ``but``, whose
        change finding (one with a ``baseline``) no operator marked ``false_alarm``: a false alarm says that image
        showed noise (a shadow, a passer-by), so the next round is measured against the image accepted before it."""
        rows = self._read(
            f"SELECT {_CAPTURE} FROM captures c WHERE target = ? AND image IS NOT NULL AND t <= ? AND id <> ?"
            " AND NOT EXISTS (SELECT 1 FROM findings f WHERE f.capture = c.id AND f.status = 'false_alarm'"
            " AND f.baseline IS NOT NULL) ORDER BY t DESC, id DESC LIMIT 1",
            (target, before, but),
        )
        return record_of(CaptureRecord, rows[0]) if rows else None

    def captures_of(self, target: str, until: float, limit: int) -> list[CaptureRecord]:
        """The newest ``limit`` captures a mission took of ``target`` at or before ``until`` (Unix s), oldest first: a
        target's last rounds (relay.inspection.trend). Captures outside a mission (a gaze's ``target/add``) are not
        rounds: taken from wherever the robot stood, their readings are of another place."""
        rows = self._read(
            f"SELECT {_CAPTURE} FROM captures WHERE target = ? AND mission IS NOT NULL AND t <= ?"
            " ORDER BY t DESC, id DESC LIMIT ?",
            (target, until, limit),
        )
        return [record_of(CaptureRecord, r) for r in reversed(rows)]

    # -- findings ---------------------------------------------------------------------------------

    def add_finding(self, finding: FindingRecord) -> FindingRecord:
        """Keep a finding; its capture must be stored (StoreError otherwise)."""
        if finding.status not in FINDING_STATUSES:
            raise ValueError(f"status must be one of {', '.join(FINDING_STATUSES)}, got {finding.status!r}")
        values = row_of(finding)
        self._write(f"INSERT INTO findings ({_FINDING}) VALUES ({', '.join('?' * len(values))})", values)
        return finding

    def update_finding(
        self,
        finding_id: str,
        *,
        status: str | None = None,
        note: str | None = None,
        region: tuple[tuple[int, int], ...] | None = None,
        updated: float,
    ) -> FindingRecord:
        """Change what is given (None: keep it); the finding as it now is. UnknownRecord if there is no such id."""
        if status is not None and status not in FINDING_STATUSES:
            raise ValueError(f"status must be one of {', '.join(FINDING_STATUSES)}, got {status!r}")
        # One statement: atomic on both databases without a SELECT ... FOR UPDATE on PostgreSQL.
        rows = self._write(
            "UPDATE findings SET status = COALESCE(?, status), note = COALESCE(?, note), "
            f"region = COALESCE(?, region), updated = ? WHERE id = ? RETURNING {_FINDING}",
            (status, note, None if region is None else json.dumps(region), updated, finding_id),
        )
        if not rows:
            raise UnknownRecord(f"no finding {finding_id[:80]!r}")
        return record_of(FindingRecord, rows[0])

    def finding(self, finding_id: str) -> FindingRecord | None:
        rows = self._read(f"SELECT {_FINDING} FROM findings WHERE id = ?", (finding_id,))
        return record_of(FindingRecord, rows[0]) if rows else None

    def findings(
        self, *, mission: str | None = None, status: str | None = None, robot: str | None = None
    ) -> list[FindingRecord]:
        """Oldest first; those matching every filter given."""
        conditions = [(c, v) for c, v in (("mission", mission), ("status", status), ("robot", robot)) if v is not None]
        where = " AND ".join(f"{c} = ?" for c, _ in conditions)
        sql = f"SELECT {_FINDING} FROM findings {'WHERE ' + where if where else ''} ORDER BY created, id"
        return [record_of(FindingRecord, r) for r in self._read(sql, [v for _, v in conditions])]

    def recent_findings(
        self, limit: int, before: float | None = None
    ) -> list[tuple[FindingRecord, CaptureRecord, str | None]]:
        """The newest ``limit`` findings (created before ``before`` when given), newest first, each with its
        capture and the SHA-256 of its baseline capture's image (None: no baseline, or no image): a page of the
        findings list, in one query."""
        names = (
            ", ".join(f"f.{c}" for c in _FINDING.split(", ")) + ", " + ", ".join(f"c.{c}" for c in _CAPTURE.split(", "))
        )
        where, args = ("WHERE f.created < ?", [before]) if before is not None else ("", [])
        rows = self._read(
            f"SELECT {names}, b.image FROM findings f JOIN captures c ON c.id = f.capture "
            f"LEFT JOIN captures b ON b.id = f.baseline {where} ORDER BY f.created DESC, f.id DESC LIMIT ?",
            [*args, limit],
        )
        split = len(fields(FindingRecord))
        return [(record_of(FindingRecord, r[:split]), record_of(CaptureRecord, r[split:-1]), r[-1]) for r in rows]

    def findings_between(self, start: float, end: float, limit: int) -> list[tuple[FindingRecord, CaptureRecord]]:
        """At most ``limit`` findings whose capture was taken in ``[start, end)`` (Unix seconds), oldest capture
        first, each with its capture: a report of a time range (relay.inspection.report). Read only.

        A finding is made at or after its capture (the rule's at the capture's time, an operator's later), so
        ``f.created >= start - 1 h`` (an hour's slack for a clock stepped back) lets the ``findings_created`` index
        skip the older history; captures have no index on their time. Measured with 100 000 findings a minute
        apart (69 days) in SQLite on this loaded 2-core machine, a day's range: a week back 7-14 ms, a month back
        130-200 ms, at the start 140-460 ms (it still reads every later finding); 70-830 ms without the condition."""
        names = (
            ", ".join(f"f.{c}" for c in _FINDING.split(", ")) + ", " + ", ".join(f"c.{c}" for c in _CAPTURE.split(", "))
        )
        rows = self._read(
            f"SELECT {names} FROM findings f JOIN captures c ON c.id = f.capture "
            "WHERE f.created >= ? AND c.t >= ? AND c.t < ? ORDER BY c.t, f.created, f.id LIMIT ?",
            (start - 3600.0, start, end, limit),
        )
        split = len(fields(FindingRecord))
        return [(record_of(FindingRecord, r[:split]), record_of(CaptureRecord, r[split:])) for r in rows]


def default_images(database: str) -> Path:
    """Where capture images go unless ``--images`` says: beside a SQLite file (``<name>-images``); for a database
    server, this user's data directory (``~/.local/share/xr-relay/images``, beside ``--tls auto``'s certificate),
    never the working directory, where they went before. Images are named by their hash, so databases may share
    the directory."""
    if "://" in database:
        return Path.home() / ".local" / "share" / "xr-relay" / "images"
    return Path(database).with_name(Path(database).stem + "-images")
