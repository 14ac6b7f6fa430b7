"""relay.inspection.store on a real SQLite file and on a real PostgreSQL server (Debian's package, started for the
session): round trips of every record, images by hash, migrations, and the failures operators meet (locked, full,
corrupt, unreachable)."""

from __future__ import annotations

import hashlib
import socket
import sqlite3
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import relay.inspection.store as store_module
from relay.inspection.records import AlertRecord, CaptureRecord, FindingRecord, MissionRecord, ReadingTrend, Step
from relay.inspection.schema import SCHEMA_VERSION
from relay.inspection.store import Store, StoreError, UnknownRecord
from tests.helpers.databases import BUSY

STEPS = (
    Step("inspect", target="spill"),
    Step("goto", x=1.25, y=-2.0, yaw=0.1 + 0.2),  # 0.30000000000000004: floats must come back bit for bit
    Step("capture"),
    Step("capture", target="valve-3"),
    Step("dwell", seconds=2.5),
    Step("goto", x=0.0, y=0.0),  # no yaw: None must stay None, not become 0
)


def _mission(**changes: Any) -> MissionRecord:
    record = MissionRecord("m-1.robot1", "Tank farm — Nord 'B' ✓", "robot1", STEPS, "running", 0, "", 10.0, 10.0, "c1")
    return replace(record, **changes)


def _capture(**changes: Any) -> CaptureRecord:
    record = CaptureRecord("c-1", "robot1", 12.0, 2.3, -7.6, -3.141592653589793, {"gas": 698.2, "temperature": 1e-300})
    return replace(record, **{"mission": "m-1.robot1", "target": "spill", "width": 640, "height": 480, **changes})


def _finding(**changes: Any) -> FindingRecord:
    record = FindingRecord("f-1", "c-1", "robot1", 1.8, 8.2, "anomaly", "gas high? 698 ppm", "rule", 13.0, 13.0)
    return replace(record, **{"mission": "m-1.robot1", "target": "spill", **changes})


JPEG = b"\xff\xd8\xff\xe0" + bytes(range(256)) * 4 + b"\xff\xd9"


# -- the databases --------------------------------------------------------------------------------------------------


@pytest.fixture
def store(url: str, tmp_path: Path) -> Iterator[Store]:
    with Store.open(url, tmp_path / "images", busy_timeout=BUSY) as opened:
        yield opened


def _raw(url: str) -> Any:
    """Another connection to the same database, in autocommit mode, as another process would have."""
    if url.startswith("postgresql://"):
        import psycopg

        return psycopg.connect(url, autocommit=True)
    return sqlite3.connect(url, isolation_level=None)


def _version(url: str) -> int:
    raw = _raw(url)
    try:
        return int(raw.execute("SELECT version FROM schema_version").fetchone()[0])
    finally:
        raw.close()


# -- round trips ----------------------------------------------------------------------------------------------------


def test_missions_round_trip_and_upsert_by_id(store: Store) -> None:
    assert store.schema_version == SCHEMA_VERSION == 7
    assert store.mission("m-1.robot1") is None and store.missions() == []
    store.save_mission(_mission())
    assert store.mission("m-1.robot1") == _mission()  # steps of every kind, unicode and quotes, exact floats
    changed = _mission(state="paused", current=2, reason="c2 takes over", updated=11.5, owner="c2", name="Renamed")
    store.save_mission(changed)  # the same id: replaced, not added
    assert store.missions() == [changed]
    done = _mission(id="m-2.robot2", robot="robot2", steps=(), state="done", created=20.0, updated=21.0)
    store.save_mission(done)
    assert [m.id for m in store.missions()] == ["m-2.robot2", "m-1.robot1"]  # newest first
    assert store.mission("m-2.robot2") == done and store.mission("m-2") is None


def test_captures_round_trip_oldest_first(store: Store) -> None:
    later = store.add_capture(_capture(id="c-late", t=50.0), JPEG)
    assert later == _capture(id="c-late", t=50.0, image=hashlib.sha256(JPEG).hexdigest())
    # No image: the record says so whatever image it came with; no readings, no mission, no target.
    bare = CaptureRecord("c-bare", "robot2", 5.0, 0.0, 0.0, 0.0, image="f" * 64)
    stored = store.add_capture(bare, None)
    assert stored == replace(bare, image=None) and stored.readings == {} and stored.mission is None
    early = store.add_capture(_capture(id="c-early", t=10.0), JPEG)
    assert store.capture("c-late") == later and store.capture("c-bare") == stored and store.capture("c-9") is None
    assert store.captures() == [stored, early, later]  # by time, not by insertion
    assert store.captures("m-1.robot1") == [early, later] and store.captures("m-9") == []


def test_findings_round_trip_and_filters(store: Store) -> None:
    store.add_capture(_capture(), JPEG)
    polygon = ((1, 2), (630, 4), (320, 470), (0, 479))
    findings = [
        _finding(id="f-late", created=30.0, updated=30.0, region=polygon),
        _finding(id="f-ok", status="ok", note="", source="operator", created=20.0, updated=20.0),
        _finding(id="f-other", robot="robot2", mission=None, target=None, status="needs_review", created=25.0),
        _finding(id="f-early", created=5.0, updated=5.0, region=()),  # an empty outline is not "no outline"
        _finding(id="f-trend", status="changed", created=26.0, updated=26.0, mission="m-2.robot1",
                 trend=ReadingTrend("gas", "ppm", 400.0, ((10.0, 199.4), (70.0, 0.1 + 0.2), (130.0, 365.8)))),
    ]  # fmt: skip
    assert [store.add_finding(f) for f in findings] == findings
    assert store.findings() == sorted(findings, key=lambda f: f.created)  # oldest first
    assert [f.id for f in store.findings(mission="m-1.robot1")] == ["f-early", "f-ok", "f-late"]
    assert [f.id for f in store.findings(status="anomaly")] == ["f-early", "f-late"]
    assert [f.id for f in store.findings(robot="robot2")] == ["f-other"]
    assert [f.id for f in store.findings(mission="m-1.robot1", status="ok", robot="robot1")] == ["f-ok"]
    assert store.findings(mission="m-1.robot1", robot="robot2") == []
    assert store.findings(status="needs_review")[0].region is None
    assert store.finding("f-trend") == findings[-1] and store.finding("f-ok").trend is None  # type: ignore[union-attr]


def test_a_targets_last_rounds_are_its_mission_captures_up_to_a_time_oldest_first(store: Store) -> None:
    """What a trend reads (relay.inspection.trend): the newest captures of the target a mission took, until then."""
    for n, t in enumerate((10.0, 70.0, 130.0, 190.0)):
        store.add_capture(_capture(id=f"c-{n}", t=t, readings={"gas": 200.0 + n}), None)
    store.add_capture(_capture(id="c-gaze", t=140.0, mission=None), None)  # a gaze's capture: not a round
    store.add_capture(_capture(id="c-panels", t=150.0, target="panels"), None)
    assert [c.id for c in store.captures_of("spill", 130.0, 10)] == ["c-0", "c-1", "c-2"]
    assert [c.id for c in store.captures_of("spill", 1e9, 2)] == ["c-2", "c-3"]
    assert store.captures_of("spill", 5.0, 10) == [] and store.captures_of("leak", 1e9, 10) == []


def test_findings_between_are_those_captured_in_the_range_oldest_capture_first(store: Store) -> None:
    """A range report's query (relay.inspection.report): by the capture's time, [start, end), with each capture."""
    for t in (9.0, 10.0, 15.0, 20.0):
        store.add_capture(_capture(id=f"c-{t:g}", t=t), None)
    # A finding made later about an early capture belongs to the capture's time; two about one capture: both.
    for fid, capture, created in (("f-a", "c-15", 15.0), ("f-b", "c-10", 16.0), ("f-c", "c-9", 9.0),
                                  ("f-d", "c-20", 20.0), ("f-e", "c-15", 15.5)):  # fmt: skip
        store.add_finding(_finding(id=fid, capture=capture, created=created, updated=created))
    found = store.findings_between(10.0, 20.0, 10)
    assert [(f.id, c.id) for f, c in found] == [("f-b", "c-10"), ("f-a", "c-15"), ("f-e", "c-15")]
    assert found[0][1] == store.capture("c-10")
    assert [f.id for f, _ in store.findings_between(10.0, 20.0, 2)] == ["f-b", "f-a"]  # the limit
    assert store.findings_between(21.0, 30.0, 10) == []


def test_update_finding_changes_only_what_is_given(store: Store) -> None:
    store.add_capture(_capture(), None)
    store.add_finding(_finding(region=((1, 1), (5, 1), (5, 5))))
    new = store.update_finding("f-1", status="needs_review", updated=14.0)
    assert new == _finding(region=((1, 1), (5, 1), (5, 5)), status="needs_review", updated=14.0)
    region = ((10, 20), (30, 40), (50, 10))
    new = store.update_finding("f-1", note="valve closed", region=region, updated=15.0)
    assert (new.status, new.note, new.region, new.updated) == ("needs_review", "valve closed", region, 15.0)
    assert store.findings() == [new]  # what it returned is what is stored
    with pytest.raises(UnknownRecord, match=r"no finding 'f-9'") as unknown:
        store.update_finding("f-9", status="ok", updated=16.0)
    assert isinstance(unknown.value, StoreError) and isinstance(unknown.value, LookupError)
    with pytest.raises(
        ValueError, match="status must be one of ok, anomaly, needs_review, changed, false_alarm, got 'broken'"
    ):
        store.update_finding("f-1", status="broken", updated=16.0)
    with pytest.raises(ValueError, match="status must be one of"):
        store.add_finding(_finding(id="f-2", status="fine"))
    assert store.findings() == [new]


def test_a_change_finding_keeps_its_score_and_baseline_and_a_false_alarm_is_no_baseline(store: Store) -> None:
    """The previous capture a round is compared with (relay.inspection.change_watch) skips a capture whose change
    finding was marked a false alarm: its image showed noise, so the one accepted before it stays the baseline."""
    for index, t in enumerate((10.0, 20.0, 30.0), 1):
        store.add_capture(_capture(id=f"c-{index}", t=t), JPEG)
    assert store.last_capture_of("spill", 30.0, "c-3") == store.capture("c-2")
    change = _finding(id="f-2", capture="c-2", status="changed", change=0.042, baseline="c-1", created=20.0)
    assert store.add_finding(change) == change and store.finding("f-2") == change  # score and baseline kept
    assert store.finding("f-2").change == 0.042  # type: ignore[union-attr]  # bit for bit
    store.add_finding(_finding(id="f-2b", capture="c-2", status="false_alarm", created=20.0))  # not a change finding
    assert store.last_capture_of("spill", 30.0, "c-3") == store.capture("c-2")
    store.update_finding("f-2", status="false_alarm", note="the lights were off", updated=25.0)
    assert store.last_capture_of("spill", 30.0, "c-3") == store.capture("c-1")
    store.update_finding("f-2", status="changed", updated=26.0)  # marked back: its image is the baseline again
    assert store.last_capture_of("spill", 30.0, "c-3") == store.capture("c-2")


def test_a_finding_needs_its_capture_and_ids_are_unique(store: Store) -> None:
    with pytest.raises(StoreError, match=r"(?i)foreign key"):  # foreign keys are on (SQLite needs a pragma)
        store.add_finding(_finding(capture="c-nowhere"))
    first = store.add_capture(_capture(), JPEG)
    with pytest.raises(StoreError, match=r"(?i)unique|duplicate"):
        store.add_capture(_capture(robot="robot9"), None)
    assert store.captures() == [first] and store.findings() == []  # nothing of the failed calls was kept


# -- images ---------------------------------------------------------------------------------------------------------


def test_images_are_stored_once_by_hash(store: Store) -> None:
    sha = hashlib.sha256(JPEG).hexdigest()
    assert store.add_capture(_capture(id="c-1"), JPEG).image == sha
    assert store.add_capture(_capture(id="c-2", t=13.0), JPEG).image == sha
    other = JPEG[:-2] + b"\x00\xff\xd9"
    other_sha = store.add_capture(_capture(id="c-3", t=14.0), other).image
    assert other_sha is not None and other_sha != sha
    files = sorted(p.relative_to(store.images).as_posix() for p in store.images.rglob("*") if p.is_file())
    assert files == sorted([f"{sha[:2]}/{sha}.jpg", f"{other_sha[:2]}/{other_sha}.jpg"])  # no temporary files left
    assert store.image(sha) == JPEG and store.image(other_sha) == other
    assert store.image("0" * 64) is None  # well-formed, not stored


def test_image_refuses_names_that_are_not_a_hash(tmp_path: Path) -> None:
    with Store.open(str(tmp_path / "a" / "inspection.sqlite"), tmp_path / "a" / "images") as store:
        # Files a path trick would reach: <images>/../../secret.jpg and one with an absolute name.
        (tmp_path / "secret.jpg").write_bytes(b"secret")
        assert (store.images / ".." / "../secret.jpg").resolve() == (tmp_path / "secret.jpg").resolve()
        sha = store.add_capture(_capture(), JPEG).image
        assert sha is not None
        for name in ("../secret", "../etc/passwd", "/etc/passwd", ("../" * 22)[:64], sha.upper(), sha + "\n", ""):
            assert store.image(name) is None, name
        assert store.image(sha) == JPEG


def test_alerts_are_acknowledged_once_and_a_late_raise_does_not_undo_it(store: Store) -> None:
    """Raised, listed while open (newest first), acknowledged once: a second acknowledgement learns it came late,
    and the raise written after the acknowledgement (a write-behind that was retrying) leaves it acknowledged."""
    first = AlertRecord("a-1", "anomaly", "robot2", "f-1", "Anomaly at Spill (robot2): gas 312.0 ppm", "critical", 5.0)
    second = AlertRecord("a-2", "mission_aborted", None, None, "Mission Round — Nord ✓ aborted", "warning", 6.5)
    store.add_alert(first)
    store.add_alert(second)
    assert store.open_alerts(10) == [second, first] and store.open_alerts(1) == [second]
    acked = replace(first, acked_by="Ana", acked_at=7.25, ack_note="valve closed, 'B' side")
    assert store.acknowledge_alert(acked) == acked
    assert store.acknowledge_alert(replace(acked, acked_by="Ben", acked_at=8.0)) is None
    store.add_alert(first)  # the raise, written late
    assert store.alert("a-1") == acked and store.open_alerts(10) == [second]
    late = AlertRecord("a-3", "threshold", "robot1", "c-9", "Past its limit", "critical", 9.0, "Ben", 9.5, "")
    assert store.acknowledge_alert(late) == late  # acknowledged before its raise was written: stored whole
    assert store.alert("nope") is None and [a.id for a in store.alerts()] == ["a-1", "a-2", "a-3"]


# -- migrations -----------------------------------------------------------------------------------------------------


def test_an_old_database_is_migrated_once(url: str, tmp_path: Path) -> None:
    if not url.startswith("postgresql://"):
        Path(url).parent.mkdir(parents=True)
    raw = _raw(url)
    raw.execute("CREATE TABLE schema_version (version INTEGER NOT NULL)")
    raw.execute("INSERT INTO schema_version (version) VALUES (0)")
    raw.close()
    with Store.open(url, tmp_path / "images") as store:
        assert store.schema_version == SCHEMA_VERSION and _version(url) == SCHEMA_VERSION
        store.add_capture(_capture(), None)
        store.add_finding(_finding())
    with Store.open(url, tmp_path / "images") as store:  # at the current version: nothing runs, nothing is lost
        assert store.findings() == [_finding()] and _version(url) == SCHEMA_VERSION


def test_a_newer_database_is_refused_untouched(url: str, tmp_path: Path) -> None:
    Store.open(url, tmp_path / "images").close()
    raw = _raw(url)
    raw.execute("UPDATE schema_version SET version = 99")
    raw.close()
    with pytest.raises(
        StoreError, match=rf"has schema version 99, newer than this relay's {SCHEMA_VERSION}: use a newer relay"
    ):
        Store.open(url, tmp_path / "images")
    assert _version(url) == 99


def test_a_second_migration_applies_or_changes_nothing(
    url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with Store.open(url, tmp_path / "images") as store:
        store.add_capture(_capture(), None)
        store.add_finding(_finding())
    broken = ("CREATE TABLE extra (id TEXT)", "ALTER TABLE no_such_table ADD COLUMN x INTEGER")
    monkeypatch.setattr(store_module, "MIGRATIONS", (*store_module.MIGRATIONS, broken))
    with pytest.raises(StoreError, match=rf"no_such_table.*\(in migration {SCHEMA_VERSION + 1}; nothing changed\)"):
        Store.open(url, tmp_path / "images")
    raw = _raw(url)
    with pytest.raises(Exception, match="extra"):  # its first statement was rolled back with the rest
        raw.execute("SELECT id FROM extra")
    raw.close()
    assert _version(url) == SCHEMA_VERSION
    added = ("ALTER TABLE findings ADD COLUMN severity INTEGER", "UPDATE findings SET severity = 2")
    monkeypatch.setattr(store_module, "MIGRATIONS", (*store_module.MIGRATIONS[:SCHEMA_VERSION], added))
    with Store.open(url, tmp_path / "images") as store:
        assert store.schema_version == SCHEMA_VERSION + 1 and _version(url) == SCHEMA_VERSION + 1
        assert store.findings() == [_finding()]  # the code reads the columns it knows
    raw = _raw(url)
    assert raw.execute("SELECT id, severity FROM findings").fetchall() == [("f-1", 2)]
    raw.close()


def test_findings_of_a_version_5_database_come_through_migration_6_without_a_change(
    url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Databases in the field made findings before a change kept its score: they read back with none."""
    monkeypatch.setattr(store_module, "MIGRATIONS", store_module.MIGRATIONS[:5])
    with Store.open(url, tmp_path / "images") as store:
        assert store.schema_version == 5
        store.add_capture(_capture(), None)
    raw = _raw(url)  # a finding as a version-5 relay wrote it: no change, no baseline column
    raw.execute(
        "INSERT INTO findings (id, capture, robot, x, y, status, note, source, created, updated, mission, target, "
        "region) VALUES ('f-1', 'c-1', 'robot1', 1.8, 8.2, 'needs_review', 'changed since the last round', 'rule', "
        "13.0, 13.0, 'm-1.robot1', 'spill', NULL)"
    )
    raw.close()
    monkeypatch.undo()
    with Store.open(url, tmp_path / "images") as store:
        assert store.schema_version == SCHEMA_VERSION == 7
        [old] = store.findings()
        assert (old.status, old.change, old.baseline) == ("needs_review", None, None)


def test_relays_opening_a_new_database_at_once_migrate_it_once(url: str, tmp_path: Path) -> None:
    barrier = threading.Barrier(4)

    def open_one(i: int) -> int:
        barrier.wait()
        with Store.open(url, tmp_path / "images", busy_timeout=10) as opened:
            opened.save_mission(_mission(id=f"m-{i}"))
            return opened.schema_version

    with ThreadPoolExecutor(4) as pool:
        assert list(pool.map(open_one, range(4))) == [SCHEMA_VERSION] * 4
    raw = _raw(url)
    assert raw.execute("SELECT version FROM schema_version").fetchall() == [(SCHEMA_VERSION,)]
    raw.close()
    with Store.open(url, tmp_path / "images") as store:
        assert sorted(m.id for m in store.missions()) == ["m-0", "m-1", "m-2", "m-3"]


# -- failures -------------------------------------------------------------------------------------------------------


def test_a_locked_database_says_so_within_the_busy_timeout(store: Store, url: str) -> None:
    store.save_mission(_mission())
    other: Any = _raw(url)
    if store.postgres:
        other.autocommit = False
        other.execute("LOCK TABLE missions IN ACCESS EXCLUSIVE MODE")  # until its transaction ends
    else:
        other.execute("BEGIN EXCLUSIVE")
        assert store.mission("m-1.robot1") == _mission()  # WAL: readers go on while another process writes
    started = time.monotonic()
    with pytest.raises(StoreError, match=rf"database {store.name} is locked by another process"):
        store.save_mission(_mission(state="paused"))
    waited = time.monotonic() - started
    assert BUSY * 0.8 <= waited < BUSY + 2.0  # it waited for the lock, then gave up
    if store.postgres:
        other.rollback()
    else:
        other.execute("ROLLBACK")
    store.save_mission(_mission(state="paused"))  # works again once the other process lets go
    assert store.mission("m-1.robot1") == _mission(state="paused")
    other.close()


def test_a_full_sqlite_database_says_so_and_keeps_what_it_had(tmp_path: Path) -> None:
    path = tmp_path / "inspection.sqlite"
    with Store.open(str(path), tmp_path / "images") as store:
        store.save_mission(_mission())
        # A full disk, without filling one: SQLite's own size limit gives the same SQLITE_FULL. The pragma is per
        # connection, so it goes to the store's own.
        pages = store._db.execute("PRAGMA page_count").fetchone()[0]
        store._db.execute(f"PRAGMA max_page_count = {pages}")
        saved = []
        with pytest.raises(StoreError, match=rf"database {path} is full"):
            for i in range(1000):
                store.save_mission(_mission(id=f"m-{i}", reason="x" * 3000))
                saved.append(f"m-{i}")
        assert {m.id for m in store.missions()} == {"m-1.robot1", *saved}  # the failed one left nothing behind
        store._db.execute(f"PRAGMA max_page_count = {pages * 100}")
        store.save_mission(_mission(id="m-after"))  # room again: the store goes on
        assert store.mission("m-after") == _mission(id="m-after")


def test_a_corrupt_sqlite_file_is_refused_untouched(tmp_path: Path) -> None:
    garbage = tmp_path / "garbage.sqlite"
    content = bytes((i * 7919 + 13) % 251 for i in range(16384))
    garbage.write_bytes(content)
    with pytest.raises(StoreError, match=rf"database {garbage} is not a SQLite database"):
        Store.open(str(garbage), tmp_path / "images")
    assert garbage.read_bytes() == content  # not overwritten: it may be someone's data
    # A real database with its tables' pages overwritten: the header is fine, the content is not.
    damaged = tmp_path / "damaged.sqlite"
    with Store.open(str(damaged), tmp_path / "images") as store:
        store.save_mission(_mission())
    with damaged.open("r+b") as file:
        file.seek(4096)
        file.write(content[: damaged.stat().st_size - 4096])
    with pytest.raises(StoreError, match=rf"database {damaged} is corrupt: database disk image is malformed"):
        Store.open(str(damaged), tmp_path / "images")  # the migration's look at schema_version finds it


def test_sqlite_file_is_created_in_wal_mode_and_a_directory_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "new" / "dirs" / "inspection.sqlite"
    with Store.open(str(path), tmp_path / "images" / "deep") as store:
        assert path.is_file() and (tmp_path / "images" / "deep").is_dir()
        assert sqlite3.connect(path).execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    with pytest.raises(StoreError, match=rf"database {store.name} is closed"):
        store.missions()
    store.close()  # twice is fine
    with pytest.raises(StoreError, match=rf"database {tmp_path} cannot be opened"):
        Store.open(str(tmp_path), tmp_path / "images")


def test_an_unreachable_postgresql_says_so_without_the_password(tmp_path: Path) -> None:
    pytest.importorskip("psycopg", reason="psycopg is not installed (pip install 'psycopg[binary]>=3.1')")
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    for url in (
        f"postgresql://relay:s3cret@127.0.0.1:{port}/x",
        f"postgresql://relay@127.0.0.1:{port}/x?password=s3cret",
    ):
        with pytest.raises(StoreError) as refused:
            Store.open(url, tmp_path / "images", busy_timeout=1)
        message = str(refused.value)
        assert message.startswith(f"database postgresql://relay@127.0.0.1:{port}/x is unreachable: "), message
        assert "s3cret" not in message


def test_postgresql_connection_lost_is_reported_then_reconnected(postgres_url: str, tmp_path: Path) -> None:
    with Store.open(postgres_url, tmp_path / "images", busy_timeout=BUSY) as store:
        store.save_mission(_mission())
        admin = _raw(postgres_url)
        admin.execute(
            "SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = current_database() "
            "AND pid <> pg_backend_pid()"
        )
        admin.close()
        with pytest.raises(StoreError, match=rf"database {store.name} (closed the connection|is unreachable)"):
            store.missions()
        assert store.missions() == [_mission()]  # the next call connects again
