"""The accounts of a site: a SQLite file of user names, roles and Argon2id hashes (``--users``, default
``./xr-relay-users.sqlite``), written by ``xr-relay users`` and read by the relay at each sign-in. A relay's first
start on a file that holds no one makes the ``admin`` account and prints its password once.

Every method opens its own connection and is blocking: the relay calls it off the event loop. A name is 1-32
letters, digits, spaces, ``.``, ``_`` or ``-``, compared without case (``Ana`` and ``ana`` are one account). The last
admin cannot be removed nor made anything else: someone must be able to manage the accounts.
"""

from __future__ import annotations

import re
import secrets
import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Final, Literal

from ..wire.messages import Role
from .passwords import hash_password
from .roles import role_of

NAME: Final = re.compile(r"[A-Za-z0-9][A-Za-z0-9 ._-]{0,31}")
#: The account a relay makes on its first start (UserBook.first_admin).
FIRST_ADMIN: Final = "admin"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS users (
    name TEXT PRIMARY KEY COLLATE NOCASE,
    role TEXT NOT NULL,
    hash TEXT NOT NULL,
    created REAL NOT NULL,
    changed REAL NOT NULL
)
"""


class AccountError(ValueError):
    """A change of the accounts that cannot be made; the message names the user or the field."""


@dataclass(frozen=True, slots=True)
class User:
    name: str
    role: Role
    created: float


def check_name(name: str) -> str:
    if not NAME.fullmatch(name):
        shown = name if len(name) <= 40 else name[:40] + "..."
        raise AccountError(
            f"user name {shown!r}: 1-32 letters, digits, spaces, '.', '_' or '-', beginning with a letter or digit"
        )
    return name


def _role(text: str) -> Role:
    try:
        return role_of(text)
    except ValueError as exc:
        raise AccountError(str(exc)) from None


class UserBook:
    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)

    def _open(self) -> sqlite3.Connection:
        connection = sqlite3.connect(self.path, timeout=5.0)
        connection.execute(_SCHEMA)
        return connection

    def users(self) -> list[User]:
        if not self.path.exists():
            return []
        with self._open() as db:
            rows = db.execute("SELECT name, role, created FROM users ORDER BY name COLLATE NOCASE").fetchall()
        return [User(name, _role(role), created) for name, role, created in rows]

    def hash_of(self, name: str) -> tuple[User, str] | None:
        """The user and their stored hash, or None (no such user; no file yet)."""
        if not self.path.exists() or not NAME.fullmatch(name):
            return None
        with self._open() as db:
            row = db.execute("SELECT name, role, created, hash FROM users WHERE name = ?", (name,)).fetchone()
        return None if row is None else (User(row[0], _role(row[1]), row[2]), row[3])

    def add(self, name: str, role: str, password: str) -> User:
        check_name(name)
        checked = _role(role)
        digest = _hashed(password)
        now = time.time()
        with self._open() as db:
            try:
                db.execute("INSERT INTO users VALUES (?, ?, ?, ?, ?)", (name, checked, digest, now, now))
            except sqlite3.IntegrityError:
                raise AccountError(f"user {name!r} exists already (xr-relay users passwd changes a password)") from None
        return User(name, checked, now)

    def first_admin(self) -> tuple[User, str] | None:
        """On a relay's first start (a users file that holds no one): the ``admin`` account with a new random
        password, returned once to be printed (never logged), or None when the file holds someone already. Two
        relays starting on one new file make one admin: the insert is the check."""
        if self.users():
            return None
        password = secrets.token_urlsafe(12)  # 96 bits, 16 characters: typed once, then changed
        try:
            return self.add(FIRST_ADMIN, "admin", password), password
        except AccountError:
            return None  # another relay made it between the check and the insert

    def set_password(self, name: str, password: str) -> None:
        digest = _hashed(password)
        with self._open() as db:
            _changed(db, name, "hash", digest)

    def set_role(self, name: str, role: str) -> None:
        checked = _role(role)
        with self._open() as db:
            self._keep_an_admin(db, name, checked)
            _changed(db, name, "role", checked)

    def remove(self, name: str) -> None:
        with self._open() as db:
            self._keep_an_admin(db, name, None)
            if db.execute("DELETE FROM users WHERE name = ?", (name,)).rowcount == 0:
                raise AccountError(f"no user {name[:40]!r}")

    @staticmethod
    def _keep_an_admin(db: sqlite3.Connection, name: str, becomes: Role | None) -> None:
        admins = [row[0].lower() for row in db.execute("SELECT name FROM users WHERE role = 'admin'")]
        if becomes != "admin" and admins == [name.lower()]:
            raise AccountError(f"{name!r} is the last admin: make another admin first")


def _changed(db: sqlite3.Connection, name: str, column: Literal["hash", "role"], value: str) -> None:
    """Set one column of ``name``'s row (``hash`` or ``role``, never from input), or say there is no such user."""
    sql = f"UPDATE users SET {column} = ?, changed = ? WHERE name = ?"
    if db.execute(sql, (value, time.time(), name)).rowcount == 0:
        raise AccountError(f"no user {name[:40]!r}")


def _hashed(password: str) -> str:
    try:
        return hash_password(password)
    except ValueError as exc:
        raise AccountError(str(exc)) from None
