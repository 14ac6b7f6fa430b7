"""Debian's PostgreSQL server binaries for the store's tests (installed once when missing and allowed)."""

from __future__ import annotations

import contextlib
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest


def postgres_binaries() -> tuple[Path | None, str]:
    """Debian's PostgreSQL binaries (the newest major version), installing the package once if it is missing."""

    def newest() -> Path | None:
        found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"), key=lambda p: p.parent.parent.name.zfill(4))
        return found[-1].parent if found and (found[-1].parent / "pg_ctl").exists() else None

    if (binaries := newest()) is not None:
        return binaries, ""
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        return None, "no PostgreSQL server in /usr/lib/postgresql, and apt-get cannot install one here (not root)"
    try:
        done = subprocess.run(
            ["apt-get", "install", "-y", "-q", "postgresql"],
            capture_output=True,
            text=True,
            timeout=500,
            env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"},
        )
        why = (done.stderr.strip().splitlines() or ["no output"])[-1]
    except subprocess.TimeoutExpired:
        why = "it took over 500 s"
    return newest(), f"no PostgreSQL server: `apt-get install -y postgresql` failed ({why})"


@contextlib.contextmanager
def running_postgres(password: str | None = None) -> Iterator[tuple[str, list[str]]]:
    """A throwaway PostgreSQL server on 127.0.0.1, user ``relay`` (trust auth; with ``password``, scram-sha-256
    asking for it): its URL without a password and the ``pg_ctl`` command line (a test may stop it); skips the test
    when no server can be had."""
    pytest.importorskip("psycopg", reason="psycopg is not installed (pip install 'psycopg[binary]>=3.1')")
    binaries, why = postgres_binaries()
    if binaries is None:
        pytest.skip(why)
    # Not under pytest's tmp_path: root's is mode 0700, and the server must run as another account (PostgreSQL
    # refuses to run as root): the package's `postgres` account, else `nobody`.
    data = Path(tempfile.mkdtemp(prefix="xr-relay-pg-"))
    run_as: list[str] = []
    if os.geteuid() == 0:
        account = "postgres" if "postgres" in {p.pw_name for p in pwd.getpwall()} else "nobody"
        shutil.chown(data, account)
        run_as = ["runuser", "-u", account, "--"]
    auth = ["-A", "trust"]
    if password is not None:
        (data / "pwfile").write_text(password + "\n")
        if run_as:
            shutil.chown(data / "pwfile", run_as[2])
        auth = ["-A", "scram-sha-256", "--pwfile", str(data / "pwfile")]
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    pg_ctl = [*run_as, str(binaries / "pg_ctl"), "-D", str(data / "db")]
    try:
        subprocess.run(
            [*run_as, str(binaries / "initdb"), "-D", str(data / "db"), *auth, "-U", "relay", "--no-sync"],
            check=True,
            capture_output=True,
        )
        # fsync off: a test server that dies loses nothing of value, and CREATE DATABASE per test gets fast.
        options = f"-c listen_addresses=127.0.0.1 -p {port} -k {data} -c fsync=off"
        started = subprocess.run(
            [*pg_ctl, "-o", options, "-l", str(data / "log"), "-w", "-t", "60", "start"], capture_output=True
        )
        if started.returncode != 0:
            log = (data / "log").read_text(errors="replace") if (data / "log").exists() else ""
            raise RuntimeError(f"PostgreSQL did not start: {started.stderr.decode(errors='replace')}\n{log}")
        yield f"postgresql://relay@127.0.0.1:{port}/postgres", pg_ctl
    finally:
        subprocess.run([*pg_ctl, "-m", "fast", "stop"], capture_output=True)
        shutil.rmtree(data, ignore_errors=True)
