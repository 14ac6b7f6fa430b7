"""relay.inspection.store on a real SQLite file (and on a real PostgreSQL server from Debian's package, when it can
be installed): round trips, images by hash, migrations, and the failures operators meet (locked, full, corrupt)."""

from __future__ import annotations

import os
import shutil
import socket
import sqlite3
import subprocess
import tempfile
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from relay.inspection.records import CaptureRecord, FindingRecord, MissionRecord, Step
from relay.inspection.report import as_csv, as_html, collect
from relay.inspection.store import SCHEMA_VERSION, Store, StoreError

STEPS = (
    Step("inspect", target="spill"),
    Step("goto", x=1.0, y=2.0, yaw=0.5),
    Step("dwell", seconds=2.0),
    Step("capture"),
)


def _mission(**fields: Any) -> MissionRecord:
    return replace(MissionRecord("m-1.robot1", "Demo", "robot1", STEPS, "running", 0, "", 10.0, 10.0, "c1"), **fields)


def _exercise(store: Store) -> None:
    store.save_mission(_mission())
    store.save_mission(_mission(state="paused", current=2, reason="c2 takes over", updated=11.0))  # an upsert
    [mission] = store.missions()
    assert (mission.state, mission.current, mission.reason, mission.steps) == ("paused", 2, "c2 takes over", STEPS)
    jpeg = b"\xff\xd8" + os.urandom(64) + b"\xff\xd9"
    capture = CaptureRecord("c-1", "robot1", 12.0, 2.3, 7.6, 2.35, {"gas": 698.2, "temperature": 21.3}, "m-1.robot1",
                            "spill", None, 480, 480)  # fmt: skip
    stored = store.add_capture(capture, jpeg)
    again = store.add_capture(replace(stored, id="c-2", image=None), jpeg)
    assert stored.image is not None and stored.image == again.image and store.image(stored.image) == jpeg
    assert len(list(store.images.rglob("*.jpg"))) == 1  # the same image, kept once
    assert store.image("../../etc/passwd") is None and store.image("0" * 64) is None
    assert store.capture("c-1") == stored and [c.id for c in store.captures("m-1.robot1")] == ["c-1", "c-2"]
    finding = FindingRecord("f-1", "c-1", "robot1", 1.8, 8.2, "anomaly", "gas high", "rule", 13.0, 13.0, "m-1.robot1",
                            "spill")  # fmt: skip
    store.add_finding(finding)
    store.add_finding(FindingRecord("f-2", "c-2", "robot2", 9.0, 9.6, "ok", "", "operator", 14.0, 14.0))
    region = ((1, 2), (30, 4), (20, 40))
    updated = store.update_finding("f-1", status="needs_review", region=region, updated=15.0)
    assert (updated.status, updated.note, updated.region, updated.updated) == ("needs_review", "gas high", region, 15.0)
    assert [f.id for f in store.findings()] == ["f-1", "f-2"]
    assert [f.id for f in store.findings(status="ok")] == ["f-2"]
    assert [f.id for f in store.findings(mission="m-1.robot1", robot="robot1")] == ["f-1"]
    with pytest.raises(StoreError, match="no finding 'f-9'"):
        store.update_finding("f-9", status="ok", updated=16.0)
    with pytest.raises(ValueError, match="status must be one of"):
        store.update_finding("f-1", status="broken", updated=16.0)
    report = collect(store, "m-1")
    assert [f.id for f in report.findings] == ["f-1"]
    assert "data:image/jpeg;base64," in as_html(report, store, None) and "f-1,needs_review" in as_csv(report)


def test_sqlite_round_trips(tmp_path: Path) -> None:
    store = Store.open(str(tmp_path / "db" / "inspection.sqlite"), tmp_path / "images")
    assert store.schema_version == SCHEMA_VERSION
    _exercise(store)
    store.close()
    reopened = Store.open(str(tmp_path / "db" / "inspection.sqlite"), tmp_path / "images")  # migrations run once
    assert len(reopened.findings()) == 2
    reopened.close()


def test_a_newer_schema_is_refused_and_an_old_one_migrated(tmp_path: Path) -> None:
    path = tmp_path / "old.sqlite"
    sqlite3.connect(path).executescript(
        "CREATE TABLE schema_version (version INTEGER); INSERT INTO schema_version VALUES (0);"
    )
    store = Store.open(str(path), tmp_path / "images")
    assert store.schema_version == SCHEMA_VERSION and store.missions() == []
    store.close()
    sqlite3.connect(path, isolation_level=None).execute("UPDATE schema_version SET version = 99")
    with pytest.raises(StoreError, match=r"old.sqlite has schema version 99, newer than this relay's"):
        Store.open(str(path), tmp_path / "images")


def test_locked_full_and_corrupt_databases_say_so(tmp_path: Path) -> None:
    path = tmp_path / "inspection.sqlite"
    store = Store.open(str(path), tmp_path / "images", busy_timeout=0.2)
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    started = time.monotonic()
    with pytest.raises(StoreError, match=r"inspection.sqlite is locked by another process"):
        store.save_mission(_mission())
    assert time.monotonic() - started < 3
    other.execute("ROLLBACK")
    store.save_mission(_mission())  # works again once the other process lets go
    # Full: the database may not grow past its current pages.
    pages = store._db.execute("PRAGMA page_count").fetchone()[0]
    store._db.execute(f"PRAGMA max_page_count = {pages}")
    with pytest.raises(StoreError, match="is full"):
        for i in range(2000):
            store.save_mission(_mission(id=f"m-{i}", reason="x" * 500))
    assert store.mission("m-1.robot1") is not None  # what was there is intact
    store.close()
    corrupt = tmp_path / "corrupt.sqlite"
    corrupt.write_bytes(os.urandom(8192))
    with pytest.raises(StoreError, match=r"corrupt.sqlite is not a database or is corrupt"):
        Store.open(str(corrupt), tmp_path / "images")


# -- PostgreSQL --------------------------------------------------------------------------------------------------


def _postgres_bin() -> Path | None:
    found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"))
    if not found and shutil.which("apt-get") and os.geteuid() == 0:
        subprocess.run(["apt-get", "install", "-y", "-q", "postgresql"], capture_output=True, timeout=600,
                       env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"})  # fmt: skip
        found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"))
    return found[-1].parent if found else None


@pytest.fixture(scope="module")
def postgres_url() -> Iterator[str]:
    pytest.importorskip("psycopg", reason="psycopg is not installed (`pip install '.[dev]'`)")
    binaries = _postgres_bin()
    if binaries is None:
        pytest.skip("no PostgreSQL server: Debian's postgresql package is not installed and could not be installed")
    # Not under pytest's tmp dir: that is private to root, and the server runs as the `postgres` account.
    data = Path(tempfile.mkdtemp(prefix="xr-relay-pg-"))
    run_as: list[str] = []
    if os.geteuid() == 0:  # PostgreSQL refuses to run as root: use the `postgres` account the package created
        shutil.chown(data, "postgres")
        run_as = ["runuser", "-u", "postgres", "--"]
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    subprocess.run([*run_as, str(binaries / "initdb"), "-D", str(data / "db"), "-A", "trust", "-U", "relay"],
                   check=True, capture_output=True)  # fmt: skip
    options = f"-c listen_addresses=127.0.0.1 -c port={port} -c unix_socket_directories={data}"
    subprocess.run([*run_as, str(binaries / "pg_ctl"), "-D", str(data / "db"), "-o", options, "-w", "-l",
                    str(data / "log"), "start"], check=True, capture_output=True)  # fmt: skip
    try:
        yield f"postgresql://relay@127.0.0.1:{port}/postgres"
    finally:
        subprocess.run([*run_as, str(binaries / "pg_ctl"), "-D", str(data / "db"), "-m", "immediate", "stop"],
                       capture_output=True)  # fmt: skip
        shutil.rmtree(data, ignore_errors=True)


def test_postgresql_round_trips(postgres_url: str, tmp_path: Path) -> None:
    store = Store.open(postgres_url, tmp_path / "images")
    assert store.schema_version == SCHEMA_VERSION
    _exercise(store)
    store.close()
    with pytest.raises(StoreError, match=r"relay:\*\*\*@|127.0.0.1"):
        Store.open(postgres_url.replace("relay@", "relay:secret@").rsplit(":", 1)[0] + ":1/postgres", tmp_path / "i",
                   busy_timeout=1)  # fmt: skip
