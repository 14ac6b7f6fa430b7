"""The audit log: every command accepted or refused, in order, surviving a SIGKILL; rotation by size."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

import aiohttp

from relay.errors import CommandRejected
from relay.station.audit import AuditLog, CommandAudit
from tests.conftest import ROOT
from tests.helpers.cli import start_process
from tests.wsclient import TestClient


async def test_scripted_session_is_in_the_audit_log_after_sigkill(tmp_path: Path) -> None:
    log = tmp_path / "audit" / "relay.jsonl"
    process, _, ws_url = await start_process("--audit-log", str(log))
    try:
        client = await TestClient.open(ws_url)
        hello = await client.hello()
        script: list[tuple[dict[str, Any], str, str | None]] = [
            ({"identifier": "robot2/goal_pose", "x": 3.0, "y": 6.0, "yaw": 1.5}, "accepted", None),
            ({"identifier": "robot2/goal_pose", "x": 99.0, "y": 6.0}, "refused", "out_of_bounds"),
            ({"identifier": "robot1/cmd_vel", "linear": 0.2, "angular": 0.1}, "accepted", None),
            ({"identifier": "robot9/cancel"}, "refused", "unknown_robot"),
            ({"identifier": "robot1/cancel"}, "accepted", None),
            ({"identifier": "estop", "robot": "robot3"}, "accepted", None),
        ]
        for message, _, _ in script:
            await client.request(message)
        process.send_signal(signal.SIGKILL)
        await process.wait()
        records: list[dict[str, Any]] = [json.loads(line) for line in log.read_text().splitlines()]
        start, *records = records
        assert (start["client"], start["identifier"], start["outcome"]) == ("relay", "relay/start", "started")
        assert [(r["identifier"], r["outcome"], r["code"]) for r in records] == [
            (m["identifier"], outcome, code) for m, outcome, code in script
        ]
        first = records[0]
        assert first["client"] == hello["client_id"] and first["role"] == "operator"
        assert first["address"] == "127.0.0.1" and first["id"] == "t1"
        assert first["values"] == {"x": 3.0, "y": 6.0, "yaw": 1.5}
        assert "outside the map" in records[1]["message"]
        assert records[2]["values"] == {"linear": 0.2, "angular": 0.1}
        assert [r["t"] for r in records] == sorted(r["t"] for r in records)
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()


def _ids(tmp_path: Path) -> list[int]:
    names = sorted(
        (p.name for p in tmp_path.iterdir()), key=lambda n: -int(n.rsplit(".", 1)[1]) if n[-1].isdigit() else 0
    )
    return [json.loads(line)["id"] for name in names for line in (tmp_path / name).read_text().splitlines()]


def _write(audit: AuditLog, ids: range) -> None:
    for i in ids:
        audit.record(
            client="c1", role="operator", address=None, identifier="robot1/cmd_vel", request_id=i,
            values={"linear": 0.1, "angular": 0.0}, outcome="accepted",
        )  # fmt: skip


def test_rotation_never_drops_the_last_hour_and_then_keeps_a_bounded_number_of_files(tmp_path: Path) -> None:
    path = tmp_path / "a.jsonl"
    audit = AuditLog(path, max_bytes=2000, backups=2)
    _write(audit, range(100))
    # Every record of the last hour is still there, in order, although that takes more than 2 backups.
    assert _ids(tmp_path) == list(range(100))
    files = len(list(tmp_path.iterdir()))
    assert files > 3
    # Two hours later those files are old: rotation drops them beyond the 2 backups, and keeps the new hour's.
    two_hours_ago = time.time() - 7200
    for old in tmp_path.iterdir():
        os.utime(old, (two_hours_ago, two_hours_ago))
    _write(audit, range(100, 130))
    audit.close()
    ids = _ids(tmp_path)
    assert ids == list(range(ids[0], 130))  # the newest records, in order, nothing missing in between
    assert len(list(tmp_path.iterdir())) < files  # the old hour's files are gone ...
    for path in tmp_path.glob("a.jsonl.*"):
        if int(path.name.rsplit(".", 1)[1]) > 2:  # ... and a file kept beyond the 2 backups ends in the new hour
            assert json.loads(path.read_text().splitlines()[-1])["id"] >= 100, path.name
    assert all(path.stat().st_size <= 2000 + 200 for path in tmp_path.iterdir())  # rotated at the size


async def test_a_relay_that_cannot_keep_its_record_moves_no_robot(tmp_path: Path) -> None:
    """/dev/full accepts the open and refuses every write: the relay still stops robots, moves none, says so."""
    process, http_url, ws_url = await start_process("--audit-log", "/dev/full")
    try:
        client = await TestClient.open(ws_url)
        await client.hello()
        moving = [
            {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0},
            {"identifier": "robot2/goal_pose", "x": 3.0, "y": 6.0},
        ]
        for message in moving:
            reply = await client.request(message)
            assert reply["identifier"] == "error" and reply["code"] == "audit_unavailable", reply
            assert "/dev/full" in reply["message"]
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        assert (await client.request({"identifier": "robot1/cancel"}))["identifier"] == "ack"
        async with aiohttp.ClientSession() as session, session.get(f"{http_url}/healthz") as response:
            health = await response.json()
        assert health["status"] == "degraded" and "/dev/full" in health["audit_error"]
    finally:
        process.kill()
        await process.wait()


async def test_an_audit_log_path_that_cannot_be_opened_is_a_clear_start_up_error(tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    result = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", "--port", "0", "--audit-log", str(blocker / "audit.jsonl"), "--no-accounts",
        stderr=asyncio.subprocess.PIPE, cwd=ROOT,
    )  # fmt: skip
    _, stderr = await asyncio.wait_for(result.communicate(), 60)
    assert result.returncode == 2
    text = stderr.decode()
    assert "--audit-log" in text and "a-file" in text and "cannot listen" not in text


def test_a_hostile_frame_makes_a_record_under_700_characters(tmp_path: Path) -> None:
    """Values, an id and a refusal's message full of characters that grow when escaped (a quote to two, a control
    character to six): clipped before escaping, they made records of 700 characters and more; now under it, and
    what is kept is the start of what was sent."""
    path = tmp_path / "a.jsonl"
    now = [0.0]
    audit = CommandAudit(AuditLog(path), clock=lambda: now[0])
    name = "Ana Maria de la Cruz Fernandes-Oliveira"  # 40 characters: the longest name a client may give
    # Not signed in (user None): a signed-in client's record carries its account instead, of at most 32 characters.
    fields = {"client_id": "c7-0123ab", "role": "operator", "address": "127.0.0.1", "name": name, "user": None}
    client = type("Client", (), fields)()
    hostile = '"\\\x01' * 200
    audit.frame(client, "target/add", hostile[:128], {"name": hostile, "note": hostile}, None)
    refused = CommandRejected("bad_request", "target/add: field 'name' " + hostile[:375])
    audit.frame(client, "target/add", hostile[:128], {"name": hostile}, refused)
    audit.frame(client, "robot1/goal_pose", "g1", {"x": 3.0, "y": 6.0}, None)
    for _ in range(8):  # past the refusals' budget: counted, and the count told in the next record written
        audit.frame(client, "target/add", hostile[:128], {"name": hostile}, refused)
    now[0] = 10.0
    audit.frame(client, "target/add", hostile[:128], {"name": hostile}, refused)
    audit.close()
    lines = path.read_text().splitlines()
    assert max(len(line) for line in lines) < 700, [len(line) for line in lines]
    first, second, plain = (json.loads(line) for line in lines[:3])
    assert json.loads(lines[-1])["message"].endswith(
        "more refused or viewer records of this client not written since the last)"
    )
    assert first["values"]["clipped"].startswith('{"name":"\\"\\\\') and hostile.startswith(first["id"])
    assert second["message"].startswith("target/add: field 'name' \"") and second["code"] == "bad_request"
    assert plain["values"] == {"x": 3.0, "y": 6.0} and plain["id"] == "g1"  # what fits is kept whole
