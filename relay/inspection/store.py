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

**The dialects differ in a few places, all in this module:** the placeholder (``?`` in the SQL written here,
rewritten to ``%s`` for psycopg by ``_sql``), how a write transaction starts (``BEGIN IMMEDIATE`` on SQLite takes
the write lock up front, so the busy timeout applies there and never half-way; ``connection.transaction()`` on
PostgreSQL), how migrations exclude each other (the same ``BEGIN IMMEDIATE``; an advisory lock on PostgreSQL) and
which error codes mean what (``_explain``). The upsert ``INSERT ... ON CONFLICT (id) DO UPDATE SET c =
excluded.c`` and ``UPDATE ... RETURNING`` are the same on both (SQLite >= 3.35). Steps, readings and regions are
JSON in TEXT columns, so the schema is one text for both.

**Schema versions** (``schema.py``). Table ``schema_version`` holds the version; ``MIGRATIONS[i]`` is the list of SQL
statements that take a database from version ``i`` to ``i + 1``. ``open`` applies the missing ones in one transaction
(all of them or none). A database newer than this code is refused: an older relay must not write into a schema it does
not know. To change the schema, append a tuple (e.g. ``("ALTER TABLE findings ADD COLUMN severity INTEGER",)``)
in SQL that both databases accept, and never edit a migration that has shipped.

**Images** are JPEG files beside the database, ``<images>/<sha256[:2]>/<sha256>.jpg``, written to a temporary file,
flushed to disk and renamed (never half-written), stored once however many captures share them. The file is
written before the capture's row, so a row never names a missing image.

**Failures** (a database locked by another process beyond ``busy_timeout``, full, corrupt, unreachable, newer than
this code) raise ``StoreError`` naming the database (a URL without its password) and what is wrong.
``busy_timeout`` is SQLite's busy timeout and PostgreSQL's ``lock_timeout``; a lost PostgreSQL connection fails the
call that meets it and is opened again by the next call (a write is never retried blind). Each method is
one transaction, so a failure leaves nothing half-written. SQLite runs in WAL mode: readers (``xr-relay report``)
neither block the relay's writes nor are blocked by them.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import math
import os
import re
import sqlite3
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import fields, replace
from pathlib import Path
from types import TracebackType
from typing import Any
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

from .records import FINDING_STATUSES, CaptureRecord, FindingRecord, MissionRecord, Target
from .rows import columns, record_of, row_of
from .schema import MIGRATIONS as MIGRATIONS  # re-exported: a test adds a migration to the store's

_SHA256 = re.compile(r"[0-9a-f]{64}")
_MIGRATION_LOCK = 0x78725F696E7370  # any constant: the PostgreSQL advisory lock that serialises relays' migrations


_MISSION, _CAPTURE, _FINDING, _TARGET = (
    columns(MissionRecord),
    columns(CaptureRecord),
    columns(FindingRecord),
    columns(Target),
)

# Primary SQLite result codes (https://sqlite.org/rescode.html) and PostgreSQL SQLSTATEs an operator can act on.
_SQLITE_PROBLEMS = {
    5: "is locked by another process",  # SQLITE_BUSY: still held when busy_timeout ran out
    6: "is locked by another process",  # SQLITE_LOCKED
    8: "is read-only",
    10: "could not be read or written (I/O error)",
    11: "is corrupt",
    13: "is full (its size limit or its disk)",
    14: "cannot be opened",
    26: "is not a SQLite database (or is corrupt)",
}
_POSTGRES_PROBLEMS = {
    "53100": "is full (the server's disk)",
    "55P03": "is locked by another process",  # lock_not_available: lock_timeout (= busy_timeout) ran out
    "40P01": "is locked by another process (deadlock)",
    "3D000": "does not exist",
    "28000": "refused the login",
    "28P01": "refused the password",
    "57P01": "closed the connection (server shut down, or the session terminated)",
    "25006": "is read-only",
    "XX001": "is corrupt",
}


class StoreError(Exception):
    """The database cannot do what was asked; the message names it and says why."""


class UnknownRecord(StoreError, LookupError):
    """No record has that id (a LookupError, as a missing key is)."""


class Store:
    """Missions, captures and findings in one database. Not thread-safe: the relay calls it from one thread."""

    def __init__(self, url: str, name: str, images: Path, busy_timeout: float) -> None:
        self._url = url  # with its password, for connecting again; messages use self.name
        self.name = name  # for messages: the absolute path, or the URL without its password
        self.images = images
        self.busy_timeout = busy_timeout
        self.postgres = url.startswith(("postgresql://", "postgres://"))
        self.schema_version = 0
        self._db: Any = None
        self._closed = False
        self._errors: tuple[type[BaseException], ...] = (sqlite3.Error,)

    @classmethod
    def open(cls, url: str, images: Path, *, busy_timeout: float = 5.0) -> Store:
        """A SQLite file (created, with its directories) or a ``postgresql://`` URL, migrated to this code's schema.

        ``busy_timeout`` (seconds) is how long a write waits for a lock another process holds, and on PostgreSQL
        also how long connecting may take, before ``StoreError``.
        """
        if url.startswith(("postgresql://", "postgres://")):
            name = _without_password(url)
        else:
            name = str(Path(url).expanduser().absolute())
        store = cls(url, name, Path(images), busy_timeout)
        try:
            store.images.mkdir(parents=True, exist_ok=True)
            store._db = store._connect()
            store._migrate()
        except OSError as exc:
            store.close()
            raise StoreError(f"database {name}: images directory {images}: {exc.strerror or exc}") from exc
        except BaseException:
            store.close()
            raise
        return store

    def _connect(self) -> Any:
        if not self.postgres:
            path = Path(self.name)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                # check_same_thread off: the thread that opens the store need not be the one that uses it (the
                # relay's store pool); calls never overlap. isolation_level None: we write BEGIN ourselves.
                db: Any = sqlite3.connect(
                    path, timeout=self.busy_timeout, isolation_level=None, check_same_thread=False
                )
            except (OSError, sqlite3.Error) as exc:
                raise StoreError(self._explain(exc)) from exc
            try:
                db.execute("PRAGMA foreign_keys = ON")  # per connection, off by default
                self._wal(db)
            except sqlite3.Error as exc:
                db.close()
                raise StoreError(self._explain(exc)) from exc
            return db
        try:
            import psycopg
        except ImportError:
            raise StoreError(
                f"database {self.name}: PostgreSQL needs psycopg (pip install 'psycopg[binary]')"
            ) from None
        self._errors = (sqlite3.Error, psycopg.Error)
        try:
            # autocommit: a read is its own statement, a write is in an explicit transaction(), nothing idles open.
            db = psycopg.connect(self._url, autocommit=True, connect_timeout=max(2, math.ceil(self.busy_timeout)))
            db.execute(f"SET lock_timeout = {max(1, round(self.busy_timeout * 1000))}")  # the busy_timeout of PG
        except psycopg.Error as exc:
            raise StoreError(self._explain(exc, connecting=True)) from exc
        return db

    def _wal(self, db: sqlite3.Connection) -> None:
        """WAL mode (kept in the file; the first read of the file also spots garbage). Switching a new file to WAL
        needs it to itself and SQLite's busy handler does not wait there: two processes opening a new database at
        once (3 runs in ~40 of the test that opens four) would fail at once, so wait as a write would."""
        deadline = time.monotonic() + self.busy_timeout
        while True:
            try:
                db.execute("PRAGMA journal_mode = WAL")
                return
            except sqlite3.OperationalError as exc:
                if exc.sqlite_errorcode & 0xFF != sqlite3.SQLITE_BUSY or time.monotonic() > deadline:
                    raise
                time.sleep(0.01)

    def _connection(self) -> Any:
        if self._closed or self._db is None:
            raise StoreError(f"database {self.name} is closed")
        if self.postgres and self._db.closed:  # the server restarted or dropped us: connect again, once per call
            self._db = self._connect()
        return self._db

    # -- transactions -----------------------------------------------------------------------------

    def _sql(self, sql: str) -> str:
        return sql.replace("?", "%s") if self.postgres else sql  # no SQL here has a literal ? or %

    @contextlib.contextmanager
    def _transaction(self) -> Iterator[Any]:
        """A write transaction: all of it or nothing. Database errors become StoreError naming the database."""
        db = self._connection()
        try:
            if self.postgres:
                with db.transaction():
                    yield db.cursor()
            else:
                db.execute("BEGIN IMMEDIATE")  # the write lock now (waiting busy_timeout), never half-way through
                try:
                    yield db.cursor()
                    db.execute("COMMIT")
                finally:
                    if db.in_transaction:  # an error, or a failed COMMIT; SQLite has rolled back itself after some
                        with contextlib.suppress(sqlite3.Error):
                            db.execute("ROLLBACK")
        except self._errors as exc:
            raise StoreError(self._explain(exc)) from exc

    def _write(self, sql: str, args: Sequence[Any]) -> list[tuple[Any, ...]]:
        with self._transaction() as cursor:
            cursor.execute(self._sql(sql), tuple(args))
            return list(cursor.fetchall()) if cursor.description else []

    def _read(self, sql: str, args: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        """One SELECT outside an explicit transaction: it sees one snapshot, and on SQLite takes no write lock."""
        db = self._connection()
        try:
            return list(db.execute(self._sql(sql), tuple(args)).fetchall())
        except self._errors as exc:
            raise StoreError(self._explain(exc)) from exc

    def _migrate(self) -> None:
        migrations = MIGRATIONS  # read when called, so a test can add a migration
        with self._transaction() as cursor:
            if self.postgres:  # two relays starting at once must not both create the tables
                cursor.execute("SELECT pg_advisory_xact_lock(%s)", (_MIGRATION_LOCK,))
            cursor.execute("CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL)")
            cursor.execute("SELECT MAX(version) FROM schema_version")
            found = cursor.fetchone()[0]
            version = 0 if found is None else int(found)
            if version > len(migrations):
                raise StoreError(
                    f"database {self.name} has schema version {version}, newer than this relay's "
                    f"{len(migrations)}: use a newer relay, or another database"
                )
            for number, steps in enumerate(migrations[version:], start=version + 1):
                for statement in steps:
                    try:
                        cursor.execute(statement)
                    except self._errors as exc:
                        raise StoreError(f"{self._explain(exc)} (in migration {number}; nothing changed)") from exc
            if found is None:
                cursor.execute(self._sql("INSERT INTO schema_version (version) VALUES (?)"), (len(migrations),))
            elif version < len(migrations):
                cursor.execute(self._sql("UPDATE schema_version SET version = ?"), (len(migrations),))
        self.schema_version = len(migrations)

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
        stored = replace(capture, image=None if jpeg is None else self._keep_image(jpeg))
        values = row_of(stored)
        self._write(f"INSERT INTO captures ({_CAPTURE}) VALUES ({', '.join('?' * len(values))})", values)
        return stored

    def _keep_image(self, jpeg: bytes) -> str:
        sha = hashlib.sha256(jpeg).hexdigest()
        path = self._image_path(sha)
        if path.exists():  # content-addressed: the same bytes are already there
            return sha
        temporary = None
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".part")
            with os.fdopen(fd, "wb") as out:
                out.write(jpeg)
                out.flush()
                os.fsync(out.fileno())  # on disk before its name is: no empty image after a power cut
            os.replace(temporary, path)
        except OSError as exc:
            if temporary is not None:
                with contextlib.suppress(OSError):
                    os.unlink(temporary)
            full = exc.errno in (errno.ENOSPC, errno.EDQUOT)
            problem = "the disk is full" if full else exc.strerror or str(exc)
            raise StoreError(f"database {self.name}: images directory {self.images}: {problem}") from exc
        return sha

    def _image_path(self, sha: str) -> Path:
        return self.images / sha[:2] / f"{sha}.jpg"

    def image(self, sha256: str) -> bytes | None:
        """The JPEG of that SHA-256 (64 lowercase hex digits, nothing else: no path), or None."""
        if not _SHA256.fullmatch(sha256):
            return None
        try:
            return self._image_path(sha256).read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise StoreError(f"database {self.name}: image {sha256}: {exc.strerror or exc}") from exc

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

    def findings(
        self, *, mission: str | None = None, status: str | None = None, robot: str | None = None
    ) -> list[FindingRecord]:
        """Oldest first; those matching every filter given."""
        conditions = [(c, v) for c, v in (("mission", mission), ("status", status), ("robot", robot)) if v is not None]
        where = " AND ".join(f"{c} = ?" for c, _ in conditions)
        sql = f"SELECT {_FINDING} FROM findings {'WHERE ' + where if where else ''} ORDER BY created, id"
        return [record_of(FindingRecord, r) for r in self._read(sql, [v for _, v in conditions])]

    def recent_findings(self, limit: int, before: float | None = None) -> list[tuple[FindingRecord, CaptureRecord]]:
        """The newest ``limit`` findings (created before ``before`` when given), newest first, each with its
        capture: a page of the findings list."""
        names = (
            ", ".join(f"f.{c}" for c in _FINDING.split(", ")) + ", " + ", ".join(f"c.{c}" for c in _CAPTURE.split(", "))
        )
        where, args = ("WHERE f.created < ?", [before]) if before is not None else ("", [])
        rows = self._read(
            f"SELECT {names} FROM findings f JOIN captures c ON c.id = f.capture {where} "
            "ORDER BY f.created DESC, f.id DESC LIMIT ?",
            [*args, limit],
        )
        split = len(fields(FindingRecord))
        return [(record_of(FindingRecord, r[:split]), record_of(CaptureRecord, r[split:])) for r in rows]

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

    # -- lifetime ---------------------------------------------------------------------------------

    def close(self) -> None:
        """Close the connection; the store then refuses every call. Closing twice is fine."""
        self._closed = True
        db, self._db = self._db, None
        if db is not None:
            with contextlib.suppress(*self._errors):
                db.close()

    def __enter__(self) -> Store:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, tb: TracebackType | None) -> None:
        self.close()

    # -- errors -----------------------------------------------------------------------------------

    def _explain(self, exc: BaseException, *, connecting: bool = False) -> str:
        """'database NAME <problem>: <the driver's words>', the problem from the error's code where it has one."""
        detail = " ".join(str(exc).split())  # psycopg's messages span lines
        problem = None
        if isinstance(exc, sqlite3.Error):
            problem = _SQLITE_PROBLEMS.get(exc.sqlite_errorcode & 0xFF)  # the primary code of an extended one
        elif self.postgres:
            state = getattr(exc, "sqlstate", None)
            problem = _POSTGRES_PROBLEMS.get(state or "")
            if problem is None and state is None and (connecting or self._db is None or self._db.closed):
                problem = "is unreachable" if connecting else "is unreachable (the connection was lost)"
        elif isinstance(exc, OSError):
            problem = "cannot be opened"
        return f"database {self.name} {problem}: {detail}" if problem else f"database {self.name}: {detail}"


def default_images(database: str) -> Path:
    """Where capture images go unless ``--images`` says: beside a SQLite file (``<name>-images``); for a database
    server, this user's data directory (``~/.local/share/xr-relay/images``, beside ``--tls auto``'s certificate),
    never the working directory, where they went before. Images are named by their hash, so databases may share
    the directory."""
    if "://" in database:
        return Path.home() / ".local" / "share" / "xr-relay" / "images"
    return Path(database).with_name(Path(database).stem + "-images")


def _without_password(url: str) -> str:
    """The URL for messages and logs: no password in the user part nor in a ``password=`` parameter."""
    parts = urlsplit(url)
    netloc = parts.netloc
    if "@" in netloc:
        user, host = netloc.rsplit("@", 1)
        netloc = f"{user.split(':', 1)[0]}@{host}"
    query = urlencode([(k, v) for k, v in parse_qsl(parts.query) if k != "password"])
    return urlunsplit((parts.scheme, netloc, parts.path, query, parts.fragment))
