"""The databases the store's tests run on (tests/test_store.py, tests/test_schedule_store.py): a PostgreSQL server
for the session (Debian's package: tests/helpers/postgres.py), a new database per test, and the store's two kinds."""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.helpers.postgres import running_postgres

BUSY = 0.3  # seconds: the busy timeout of the tests, short so that a lock test takes well under a second


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[str]:
    """A throwaway PostgreSQL server on 127.0.0.1 (trust auth, user ``relay``) for the session; its admin URL."""
    with running_postgres() as (url, _):
        yield url


_DATABASES = itertools.count()


@pytest.fixture
def postgres_url(postgres_server: str) -> str:
    """A new, empty database on the session's server: tests do not see each other's rows."""
    import psycopg

    name = f"test_{os.getpid()}_{next(_DATABASES)}"
    with psycopg.connect(postgres_server, autocommit=True) as admin:
        admin.execute(f"CREATE DATABASE {name}")
    return postgres_server.rsplit("/", 1)[0] + "/" + name


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.timeout(900))])
def url(request: pytest.FixtureRequest, tmp_path: Path) -> str:
    """Where a store lives: a SQLite file in a directory not yet made, or a PostgreSQL database."""
    if request.param == "sqlite":
        return str(tmp_path / "db" / "inspection.sqlite")
    return str(request.getfixturevalue("postgres_url"))
