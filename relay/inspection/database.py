"""One DB-API connection to SQLite or PostgreSQL: the dialects, write transactions, schema migrations, and errors that
name the database. relay/inspection/store.py keeps the inspection records in it.

**The dialects differ in a few places, all in this module:** the placeholder (``?`` in the SQL written here,
rewritten to ``%s`` for psycopg by ``_sql``), how a write transaction starts (``BEGIN IMMEDIATE`` on SQLite takes
the write lock up front, so the busy timeout applies there and never half-way; ``connection.transaction()`` on
PostgreSQL), how migrations exclude each other (the same ``BEGIN IMMEDIATE``; an advisory lock on PostgreSQL) and
which error codes mean what (``_explain``). The upsert ``INSERT ... ON CONFLICT (id) DO UPDATE SET c =
excluded.c`` and ``UPDATE ... RETURNING`` are the same on both (SQLite >= 3.35). Steps, readings and regions are
JSON in TEXT columns, so the schema is one text for both.

**Schema versions** (``schema.py``). Table ``schema_version`` holds the version; ``MIGRATIONS[i]`` is the list of SQL
statements that take a database from version ``i`` to ``i + 1``. ``Store.open`` applies the missing ones in one
transaction (all of them or none: ``Database._migrate``). A database newer than this code is refused: an older relay
must not write into a schema it does not know. To change the schema, append a tuple (e.g. ``("ALTER TABLE findings
ADD COLUMN severity INTEGER",)``) in SQL that both databases accept, and never edit a migration that has shipped.

**Failures** (a database locked by another process beyond ``busy_timeout``, full, corrupt, unreachable, newer than
this code) raise ``StoreError`` naming the database (a URL without its password) and what is wrong.
``busy_timeout`` is SQLite's busy timeout and PostgreSQL's ``lock_timeout``; a lost PostgreSQL connection fails the
call that meets it and is opened again by the next call (a write is never retried blind). Each method is
one transaction, so a failure leaves nothing half-written. SQLite runs in WAL mode: readers (``xr-relay report``)
neither block the relay's writes nor are blocked by them.
"""

from __future__ import annotations

import contextlib
import math
import sqlite3
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, Self
from urllib.parse import parse_qsl, urlencode, urlsplit, urlunsplit

_MIGRATION_LOCK = 0x78725F696E7370  # any constant: the PostgreSQL advisory lock that serialises relays' migrations

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


class Database:
    """One connection, opened again when PostgreSQL lost it. Not thread-safe: the relay calls it from one thread."""

    def __init__(self, url: str, busy_timeout: float) -> None:
        self._url = url  # with its password, for connecting again; messages use self.name
        self.postgres = url.startswith(("postgresql://", "postgres://"))
        #: For messages: the absolute path, or the URL without its password.
        self.name = _without_password(url) if self.postgres else str(Path(url).expanduser().absolute())
        self.busy_timeout = busy_timeout
        self.schema_version = 0
        self._db: Any = None
        self._closed = False
        self._errors: tuple[type[BaseException], ...] = (sqlite3.Error,)

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

    def _migrate(self, migrations: Sequence[Sequence[str]]) -> None:
        """Take the database to ``len(migrations)``, all of the missing steps or none."""
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

    def close(self) -> None:
        """Close the connection; the store then refuses every call. Closing twice is fine."""
        self._closed = True
        db, self._db = self._db, None
        if db is not None:
            with contextlib.suppress(*self._errors):
                db.close()

    def __enter__(self) -> Self:
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


def _without_password(url: str) -> str:
    """The URL for messages and logs: no password in the user part nor in a ``password=`` parameter."""
    parts = urlsplit(url)
    netloc = parts.netloc
    if "@" in netloc:
        user, host = netloc.rsplit("@", 1)
        netloc = f"{user.split(':', 1)[0]}@{host}"
    query = urlencode([(k, v) for k, v in parse_qsl(parts.query) if k != "password"])
    return urlunsplit((parts.scheme, netloc, parts.path, query, parts.fragment))
