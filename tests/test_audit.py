"""The audit log: every command accepted or refused, in order, surviving a SIGKILL; rotation by size."""

from __future__ import annotations

import asyncio
import json
import signal
import sys
from pathlib import Path
from typing import Any

import aiohttp

from relay.audit import AuditLog
from tests.conftest import ROOT
from tests.test_cli import start_process
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


def test_rotation_keeps_a_bounded_number_of_files(tmp_path: Path) -> None:
    path = tmp_path / "a.jsonl"
    audit = AuditLog(path, max_bytes=2000, backups=2)
    for i in range(100):
        audit.record(
            client="c1", role="operator", address=None, identifier="robot1/cmd_vel", request_id=i,
            values={"linear": 0.1, "angular": 0.0}, outcome="accepted",
        )  # fmt: skip
    audit.close()
    files = sorted(p.name for p in tmp_path.iterdir())
    assert files == ["a.jsonl", "a.jsonl.1", "a.jsonl.2"]
    ids = [
        json.loads(line)["id"]
        for name in ("a.jsonl.2", "a.jsonl.1", "a.jsonl")
        for line in (tmp_path / name).read_text().splitlines()
    ]
    assert ids == sorted(ids) and ids[-1] == 99  # the newest records, in order, across the rotated files
    assert all((tmp_path / f).stat().st_size <= 2000 + 200 for f in files)


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
        sys.executable, "-m", "relay", "--port", "0", "--audit-log", str(blocker / "audit.jsonl"),
        stderr=asyncio.subprocess.PIPE, cwd=ROOT,
    )  # fmt: skip
    _, stderr = await asyncio.wait_for(result.communicate(), 60)
    assert result.returncode == 2
    text = stderr.decode()
    assert "--audit-log" in text and "a-file" in text and "cannot listen" not in text
