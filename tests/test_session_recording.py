"""A relay started with --record-session (issue #34) records the session as MCAP: the robots' poses as every client
got them, each command with the client that sent it, and the answer it got; the file opens in the `mcap` library's
reader after the relay stops, and a place it cannot write stops the start with a message naming it."""

from __future__ import annotations

from pathlib import Path

import orjson
import pytest
from mcap.reader import make_reader

from relay.cli.main import main
from relay.cli.options import Options
from relay.config import FleetConfig
from tests.conftest import ROOT, start_relay
from tests.wsclient import TestClient


async def test_the_session_is_recorded_and_reads_back(fleet_config: FleetConfig, tmp_path: Path) -> None:
    path = tmp_path / "sessions" / "today.mcap"
    running = await start_relay(fleet_config, options=Options(backend="sim", record_session=str(path)))
    try:
        client = await TestClient.open(running.ws_url)
        hello = await client.hello()
        me = hello["client_id"]
        goal = {"identifier": "robot1/goal_pose", "x": 2.8, "y": 7.0, "yaw": 0.0}
        reply = await client.request(goal)
        await client.wait_for(lambda m: m["identifier"] == "robot1/pose", timeout=20)
        await client.send_raw("{not json")  # a frame the relay refuses is recorded too, as what was sent
        await client.wait_for(lambda m: m["identifier"] == "error", timeout=20)
        got = [m for _, m in client.messages if m["identifier"] == "robot1/pose"]
        await client.close()
    finally:
        await running.runner.cleanup()
    with path.open("rb") as f:
        reader = make_reader(f)
        messages = [(channel.topic, orjson.loads(m.data)) for _, channel, m in reader.iter_messages()]
    sent = [m["frame"] for topic, m in messages if topic == f"/in/{me}"]
    assert orjson.loads(sent[0]) == {**goal, "id": reply["id"]}, "the goal, as the client sent it"
    assert sent[-1] == "{not json"
    answers = [m for topic, m in messages if topic == f"/out/{me}"]
    assert any(a["identifier"] == "ack" and a.get("id") == reply["id"] for a in answers), "the goal's answer"
    assert any(a.get("identifier") == "error" for a in answers), "the refusal of the bad frame"
    poses = [m for topic, m in messages if topic == "/out/robot1/pose"]
    assert got and all(p in poses for p in got), "every pose the client got is in the record"


def test_a_place_the_session_cannot_be_recorded_stops_the_start(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    status = main(
        [
            "--config", str(ROOT / "robots.yaml"), "--port", "0", "--no-accounts", "--audit-log", "",
            "--database", str(tmp_path / "db.sqlite"), "--record-session", str(blocked / "s.mcap"),
        ]
    )  # fmt: skip
    assert status == 2
    assert f"cannot record the session to {blocked / 's.mcap'}" in caplog.text
