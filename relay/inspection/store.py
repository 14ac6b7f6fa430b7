"""Where missions, captures and findings are kept: SQLite by default, PostgreSQL when given a URL.

One SQL layer for both, plain DB-API (sqlite3 from the standard library; psycopg 3 for PostgreSQL, imported only
when a ``postgresql://`` URL is given): the relay's queries are a handful of inserts, upserts and filtered selects,
which an ORM would not shorten, and the dialects differ only in their placeholder (``?`` vs ``%s``, rewritten in
``_sql``). ``INSERT ... ON CONFLICT (id) DO UPDATE`` is the upsert of both. Steps, readings and regions are JSON
text, so the schema is the same on both.

**Schema versions.** ``schema_version`` holds the version; ``MIGRATIONS[i]`` takes a database from version ``i`` to
``i + 1`` and runs in one transaction at ``open``. A database newer than this code is refused (an older relay must
not write into a schema it does not know).

**Images** are JPEG files beside the database, ``<images>/<sha256[:2]>/<sha256>.jpg``, written to a temporary file
and renamed (never half-written), stored once however many captures share them.

**Failures** (a database locked by another process beyond ``busy_timeout``, a full disk, a corrupt file, an
unreachable server) raise ``StoreError`` naming the database; every method is one transaction, so nothing is
half-written. SQLite runs in WAL mode (readers do not block the relay's writes).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import sqlite3
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from .records import FINDING_STATUSES, CaptureRecord, FindingRecord, MissionRecord, Step

MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (
        """CREATE TABLE missions (id TEXT PRIMARY KEY, name TEXT NOT NULL, robot TEXT NOT NULL, steps TEXT NOT NULL,
        state TEXT NOT NULL, current INTEGER NOT NULL, reason TEXT NOT NULL, created DOUBLE PRECISION NOT NULL,
        updated DOUBLE PRECISION NOT NULL, owner TEXT NOT NULL)""",
        """CREATE TABLE captures (id TEXT PRIMARY KEY, robot TEXT NOT NULL, t DOUBLE PRECISION NOT NULL,
        x DOUBLE PRECISION NOT NULL, y DOUBLE PRECISION NOT NULL, yaw DOUBLE PRECISION NOT NULL,
        readings TEXT NOT NULL, mission TEXT, target TEXT, image TEXT, width INTEGER NOT NULL,
        height INTEGER NOT NULL)""",
        """CREATE TABLE findings (id TEXT PRIMARY KEY, capture TEXT NOT NULL REFERENCES captures (id),
        robot TEXT NOT NULL, x DOUBLE PRECISION NOT NULL, y DOUBLE PRECISION NOT NULL, status TEXT NOT NULL,
        note TEXT NOT NULL, source TEXT NOT NULL, created DOUBLE PRECISION NOT NULL,
        updated DOUBLE PRECISION NOT NULL, mission TEXT, target TEXT, region TEXT)""",
        "CREATE INDEX captures_mission ON captures (mission)",
        "CREATE INDEX findings_mission ON findings (mission)",
    ),
)
SCHEMA_VERSION = len(MIGRATIONS)
_SHA = re.compile(r"^[0-9a-f]{64}$")
_MISSION = "id, name, robot, steps, state, current, reason, created, updated, owner"
_CAPTURE = "id, robot, t, x, y, yaw, readings, mission, target, image, width, height"
_FINDING = "id, capture, robot, x, y, status, note, source, created, updated, mission, target, region"


class StoreError(Exception):
    """The database cannot do what was asked; the message names it and says why."""


class Store:
    def __init__(self, connection: Any, name: str, images: Path, postgres: bool) -> None:
        self._db = connection
        self.name = name
        self.images = images
        self._postgres = postgres
        self.schema_version = 0

    @classmethod
    def open(cls, url: str, images: Path, *, busy_timeout: float = 5.0) -> Store:
        """A SQLite file (created with its directory) or a ``postgresql://`` URL; migrated to this code's schema."""
        postgres = url.startswith(("postgresql://", "postgres://"))
        name = re.sub(r"//([^:/@]+):[^@]*@", r"//\1:***@", url)  # never a password in a message
        try:
            if postgres:
                import psycopg

                connection: Any = psycopg.connect(url, connect_timeout=max(1, int(busy_timeout)))
            else:
                Path(url).parent.mkdir(parents=True, exist_ok=True)
                connection = sqlite3.connect(url, timeout=busy_timeout, isolation_level=None, check_same_thread=False)
                connection.execute("PRAGMA journal_mode=WAL")
                connection.execute("PRAGMA foreign_keys=ON")
            images.mkdir(parents=True, exist_ok=True)
        except ImportError:
            raise StoreError(f"database {name}: PostgreSQL needs psycopg (`pip install 'psycopg[binary]'`)") from None
        except Exception as exc:
            raise StoreError(_explain(name, exc)) from None
        store = cls(connection, name, images, postgres)
        store._migrate()
        return store

    # -- transactions -----------------------------------------------------------------------------

    def _sql(self, sql: str) -> str:
        return sql.replace("?", "%s") if self._postgres else sql

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[Any]:
        try:
            if self._postgres:
                with self._db.transaction():
                    yield self._db.cursor()
            else:
                cursor = self._db.cursor()
                cursor.execute("BEGIN IMMEDIATE")  # take the write lock now: no deadlock half-way through
                try:
                    yield cursor
                except BaseException:
                    if self._db.in_transaction:  # SQLite has already rolled back after some errors (SQLITE_FULL)
                        cursor.execute("ROLLBACK")
                    raise
                cursor.execute("COMMIT")
        except StoreError:
            raise
        except Exception as exc:
            if isinstance(exc, KeyError | ValueError):
                raise
            raise StoreError(_explain(self.name, exc)) from None

    def _run(self, sql: str, args: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        with self._transaction() as cursor:
            cursor.execute(self._sql(sql), tuple(args))
            return list(cursor.fetchall()) if cursor.description else []

    def _migrate(self) -> None:
        with self._transaction() as cursor:
            cursor.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
            cursor.execute("SELECT version FROM schema_version")
            row = cursor.fetchone()
            version = 0 if row is None else int(row[0])
            if version > SCHEMA_VERSION:
                raise StoreError(
                    f"database {self.name} has schema version {version}, newer than this relay's {SCHEMA_VERSION}: "
                    "use a newer relay, or another database"
                )
            for steps in MIGRATIONS[version:]:
                for statement in steps:
                    cursor.execute(statement)
            if row is None:
                cursor.execute(self._sql("INSERT INTO schema_version (version) VALUES (?)"), (SCHEMA_VERSION,))
            else:
                cursor.execute(self._sql("UPDATE schema_version SET version = ?"), (SCHEMA_VERSION,))
        self.schema_version = SCHEMA_VERSION

    # -- missions ---------------------------------------------------------------------------------

    def save_mission(self, mission: MissionRecord) -> None:
        steps = json.dumps([_step_dict(s) for s in mission.steps])
        self._run(
            f"INSERT INTO missions ({_MISSION}) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?) ON CONFLICT (id) DO UPDATE SET "
            "state = excluded.state, current = excluded.current, reason = excluded.reason, updated = excluded.updated",
            (mission.id, mission.name, mission.robot, steps, mission.state, mission.current, mission.reason,
             mission.created, mission.updated, mission.owner),
        )  # fmt: skip

    def mission(self, mission_id: str) -> MissionRecord | None:
        rows = self._run(f"SELECT {_MISSION} FROM missions WHERE id = ?", (mission_id,))
        return _mission(rows[0]) if rows else None

    def missions(self) -> list[MissionRecord]:
        return [_mission(r) for r in self._run(f"SELECT {_MISSION} FROM missions ORDER BY created DESC, id")]

    # -- captures and images ----------------------------------------------------------------------

    def add_capture(self, capture: CaptureRecord, jpeg: bytes | None) -> CaptureRecord:
        image = None if jpeg is None else self._keep_image(jpeg)
        stored = CaptureRecord(**{**_fields(capture), "image": image})
        self._run(
            f"INSERT INTO captures ({_CAPTURE}) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (stored.id, stored.robot, stored.t, stored.x, stored.y, stored.yaw, json.dumps(stored.readings),
             stored.mission, stored.target, stored.image, stored.width, stored.height),
        )  # fmt: skip
        return stored

    def _keep_image(self, jpeg: bytes) -> str:
        sha = hashlib.sha256(jpeg).hexdigest()
        path = self._image_path(sha)
        if not path.exists():
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, temporary = tempfile.mkstemp(dir=path.parent, suffix=".part")
                with os.fdopen(fd, "wb") as out:
                    out.write(jpeg)
                os.replace(temporary, path)
            except OSError as exc:
                raise StoreError(f"images of {self.name} in {self.images}: {exc.strerror or exc}") from None
        return sha

    def _image_path(self, sha: str) -> Path:
        return self.images / sha[:2] / f"{sha}.jpg"

    def image(self, sha256: str) -> bytes | None:
        if not _SHA.match(sha256):
            return None
        try:
            return self._image_path(sha256).read_bytes()
        except FileNotFoundError:
            return None

    def capture(self, capture_id: str) -> CaptureRecord | None:
        rows = self._run(f"SELECT {_CAPTURE} FROM captures WHERE id = ?", (capture_id,))
        return _capture(rows[0]) if rows else None

    def captures(self, mission_id: str | None = None) -> list[CaptureRecord]:
        where, args = ("WHERE mission = ?", (mission_id,)) if mission_id is not None else ("", ())
        return [_capture(r) for r in self._run(f"SELECT {_CAPTURE} FROM captures {where} ORDER BY t, id", args)]

    # -- findings ---------------------------------------------------------------------------------

    def add_finding(self, finding: FindingRecord) -> FindingRecord:
        self._run(
            f"INSERT INTO findings ({_FINDING}) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (finding.id, finding.capture, finding.robot, finding.x, finding.y, finding.status, finding.note,
             finding.source, finding.created, finding.updated, finding.mission, finding.target,
             None if finding.region is None else json.dumps(finding.region)),
        )  # fmt: skip
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
        if status is not None and status not in FINDING_STATUSES:
            raise ValueError(f"status must be one of {', '.join(FINDING_STATUSES)}, got {status!r}")
        with self._transaction() as cursor:
            cursor.execute(self._sql(f"SELECT {_FINDING} FROM findings WHERE id = ?"), (finding_id,))
            row = cursor.fetchone()
            if row is None:
                raise StoreError(f"database {self.name}: no finding {finding_id[:80]!r}")
            old = _finding(row)
            new = FindingRecord(
                **{
                    **_fields(old),
                    "status": status or old.status,
                    "note": old.note if note is None else note,
                    "region": old.region if region is None else region,
                    "updated": updated,
                }
            )
            cursor.execute(
                self._sql("UPDATE findings SET status = ?, note = ?, region = ?, updated = ? WHERE id = ?"),
                (new.status, new.note, None if new.region is None else json.dumps(new.region), updated, finding_id),
            )
        return new

    def findings(
        self, *, mission: str | None = None, status: str | None = None, robot: str | None = None
    ) -> list[FindingRecord]:
        conditions = [(c, v) for c, v in (("mission", mission), ("status", status), ("robot", robot)) if v is not None]
        where = " AND ".join(f"{c} = ?" for c, _ in conditions)
        sql = f"SELECT {_FINDING} FROM findings {'WHERE ' + where if where else ''} ORDER BY created, id"
        return [_finding(r) for r in self._run(sql, [v for _, v in conditions])]

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._db.close()


def _explain(name: str, exc: BaseException) -> str:
    text = str(exc)
    lower = text.lower()
    if "locked" in lower or "busy" in lower:
        return f"database {name} is locked by another process: {text}"
    if "full" in lower:
        return f"database {name} is full (or its disk is): {text}"
    if "not a database" in lower or "malformed" in lower:
        return f"database {name} is not a database or is corrupt: {text}"
    return f"database {name}: {text}"


def _fields(record: Any) -> dict[str, Any]:
    return {name: getattr(record, name) for name in record.__dataclass_fields__}


def _step_dict(step: Step) -> dict[str, Any]:
    return {k: v for k, v in _fields(step).items() if v is not None}


def _mission(row: tuple[Any, ...]) -> MissionRecord:
    steps = tuple(Step(**s) for s in json.loads(row[3]))
    return MissionRecord(row[0], row[1], row[2], steps, row[4], int(row[5]), row[6], row[7], row[8], row[9])


def _capture(row: tuple[Any, ...]) -> CaptureRecord:
    return CaptureRecord(
        row[0], row[1], row[2], row[3], row[4], row[5], json.loads(row[6]), row[7], row[8], row[9], row[10], row[11]
    )


def _finding(row: tuple[Any, ...]) -> FindingRecord:
    region = None if row[12] is None else tuple((int(u), int(v)) for u, v in json.loads(row[12]))
    return FindingRecord(
        row[0], row[1], row[2], row[3], row[4], row[5], row[6], row[7], row[8], row[9], row[10], row[11], region
    )
