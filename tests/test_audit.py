"""The audit log: every command accepted or refused, in order, surviving a SIGKILL; rotation by size."""

from __future__ import annotations

import json
import signal
from pathlib import Path
from typing import Any

from relay.audit import AuditLog
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
