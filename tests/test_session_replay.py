"""A recorded session replayed (issue #34): `xr-relay replay FILE` serves a session recorded with --record-session on
the bag backend's timeline. A relay on the simulated fleet records a real WebSocket client driving robot1; a replay
relay on that file gives a real client the robots' poses equal to the record (within 1 mm, matched by their stamps),
lands a seek within 0.5 s of its target, pauses, resumes and changes speed, and refuses every motion command; a file
that is not a finished session recording stops the start with an error naming it, and stays as it was."""

from __future__ import annotations

import asyncio
import math
import re
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import orjson
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from relay.cli.main import main
from relay.cli.options import Options, ReplayOptions
from relay.config import FleetConfig, load_config
from relay.errors import ProtocolError
from relay.replay.backend import ReplayBackend
from relay.session.protocol import parse_command
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.wsclient import TestClient

#: How long the recorded client drives robot1 (s), at the page's 20 Hz.
DRIVE_S = 3.0


def _viewer(k: int) -> dict[str, Any]:
    """The recorded operator's viewpoint at step ``k``: walking along x, looking and pointing north-east."""
    look = [math.sqrt(0.5), math.sqrt(0.5), 0.0]
    hands = [{"hand": "right", "position": [2.2 + 0.01 * k, 3.0, 1.1], "ray": [0.6, 0.8, 0.0]}]
    return {"identifier": "viewer", "head": {"position": [2.0 + 0.01 * k, 3.0, 1.6], "look": look}, "hands": hands}


async def _record(path: Path) -> None:
    config = load_config(ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(backend="sim", record_session=str(path)))
    try:
        client = await TestClient.open(running.ws_url)
        await client.hello()
        await client.request({"identifier": "name", "name": "Ana"})
        start = len(client.messages)
        await client.send({**_viewer(0), "head": {"position": [1.0, 2.0, 1.6], "look": [1.0, 1.0, 0.0]}})
        refusal = await client.wait_for(lambda m: m["identifier"] == "error", start=start)
        assert refusal["code"] == "bad_request" and "head.look must be a unit vector" in refusal["message"]
        for k in range(round(DRIVE_S * 20)):
            await client.send({"identifier": "robot1/cmd_vel", "linear": 0.4, "angular": 0.3})
            if k % 5 == 0:  # the page's 4 Hz
                await client.send(_viewer(k))
            await asyncio.sleep(0.05)
        await client.send({"identifier": "robot1/cmd_vel", "linear": 0.0, "angular": 0.0})
        await client.close()
    finally:
        await running.runner.cleanup()


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One recorded session for the module's tests (a few seconds of the simulated fleet)."""
    path = tmp_path_factory.mktemp("sessions") / "drive.mcap"
    asyncio.run(_record(path))
    return path


class Record:
    """What the file holds: every robot pose by its robot and stamp, with its time from the session's start (s)."""

    def __init__(self, path: Path) -> None:
        with path.open("rb") as f:
            reader = make_reader(f)
            summary = reader.get_summary()
            assert summary is not None and summary.statistics is not None
            self.start_ns = summary.statistics.message_start_time
            self.duration = (summary.statistics.message_end_time - self.start_ns) * 1e-9
            self.poses: dict[tuple[str, float], tuple[float, dict[str, Any]]] = {}
            for _, channel, message in reader.iter_messages():
                if channel.topic.startswith("/out/") and channel.topic.endswith("/pose"):
                    pose = orjson.loads(message.data)
                    robot = channel.topic.split("/")[2]
                    self.poses[robot, pose["stamp"]] = ((message.log_time - self.start_ns) * 1e-9, pose)

    def first(self, robot: str) -> float:
        """When the robot's first pose was recorded (s from the session's start)."""
        return min(t for (name, _), (t, _) in self.poses.items() if name == robot)

    def at(self, message: dict[str, Any]) -> tuple[float, dict[str, Any]]:
        """The recorded time and pose of a replayed pose message (by its robot and stamp)."""
        return self.poses[message["identifier"].partition("/")[0], message["stamp"]]


@pytest.fixture(scope="module")
def record(session: Path) -> Record:
    return Record(session)


@pytest.fixture
async def replay(fleet_config: FleetConfig, session: Path) -> AsyncIterator[RunningRelay]:
    running = await start_relay(fleet_config, options=Options(backend="replay", replay=ReplayOptions(str(session))))
    try:
        yield running
    finally:
        await running.runner.cleanup()


def _poses(client: TestClient, start: int = 0) -> list[dict[str, Any]]:
    return [m for _, m in client.messages[start:] if m["identifier"].endswith("/pose")]


async def test_replayed_poses_equal_the_record(replay: RunningRelay, record: Record) -> None:
    assert isinstance(replay.relay.backend, ReplayBackend)
    client = await TestClient.open(replay.ws_url)
    hello = await client.hello()
    assert hello["playback"]["duration"] == pytest.approx(record.duration, abs=1e-3)
    assert (await client.request({"identifier": "playback/rate", "rate": 4.0}))["identifier"] == "ack"
    # The end of the session: playback pauses there (no --loop).
    await client.wait_for(lambda m: m["identifier"] == "playback" and m["paused"], timeout=30)
    got = [p for p in _poses(client) if p["identifier"] == "robot1/pose"]
    assert len(got) > 10
    for pose in _poses(client):
        _, recorded = record.at(pose)
        assert math.hypot(pose["x"] - recorded["x"], pose["y"] - recorded["y"]) <= 0.001
        # The same message but for yaw, which is derived again from the recorded (rounded) quaternion.
        assert {**pose, "yaw": 0} == {**recorded, "yaw": 0}
        assert pose["yaw"] == pytest.approx(recorded["yaw"], abs=1e-5)
    assert max(math.hypot(p["x"] - got[0]["x"], p["y"] - got[0]["y"]) for p in got) > 0.2, "robot1 drove"
    times = [record.at(p)[0] for p in got]
    assert times == sorted(times), "in the recorded order"
    avatars = [m for _, m in client.messages if m["identifier"] == "avatar"]
    assert len(avatars) >= 3, "the recorded operator's viewpoints, a few a second"
    sent = {round(_viewer(k)["head"]["position"][0], 3): _viewer(k) for k in range(0, round(DRIVE_S * 20), 5)}
    for avatar in avatars:
        assert avatar["name"] == "Ana"
        viewer = sent[avatar["head"]["position"][0]]
        assert avatar["head"]["position"] == pytest.approx(viewer["head"]["position"], abs=1e-3)
        assert avatar["head"]["look"] == pytest.approx(viewer["head"]["look"], abs=1e-4)
        assert [h["hand"] for h in avatar["hands"]] == ["right"]
        assert avatar["hands"][0]["position"] == pytest.approx(viewer["hands"][0]["position"], abs=1e-3)
        assert avatar["hands"][0]["ray"] == pytest.approx(viewer["hands"][0]["ray"], abs=1e-4)
    await client.close()


async def test_seek_lands_within_half_a_second_and_pause_resume_rate(replay: RunningRelay, record: Record) -> None:
    client = await TestClient.open(replay.ws_url)
    await client.hello()
    assert (await client.request({"identifier": "playback/pause"}))["identifier"] == "ack"
    await client.wait_for(lambda m: m["identifier"] == "playback" and m["paused"])
    # Every second of the session with robot1 in it, out of order, and one between two poses.
    seconds = list(range(math.ceil(record.first("robot1")), math.floor(record.duration) + 1))
    for target in [*seconds[1::2], *seconds[::2], seconds[0] + 0.55]:
        start = len(client.messages)
        assert (await client.request({"identifier": "playback/seek", "t": target}))["identifier"] == "ack"
        shown = await client.wait_for(lambda m: m["identifier"] == "playback", start=start)
        assert shown["paused"] and shown["position"] == pytest.approx(target, abs=1e-3)

        def near(m: dict[str, Any], target: float = target) -> bool:
            return m["identifier"] == "robot1/pose" and abs(record.at(m)[0] - target) <= 0.5

        landed = await client.wait_for(near, timeout=10, start=start)  # TimeoutError: did not land
        after = client.messages.index(next(x for x in client.messages[start:] if x[1] is landed))
        for pose in _poses(client, after):
            assert record.at(pose)[0] <= target + 0.5, "paused at the target: nothing later is played"
    start = len(client.messages)
    assert (await client.request({"identifier": "playback/seek", "t": 0.0}))["identifier"] == "ack"
    assert (await client.request({"identifier": "playback/rate", "rate": 2.0}))["identifier"] == "ack"
    assert (await client.request({"identifier": "playback/resume"}))["identifier"] == "ack"
    playing = await client.wait_for(lambda m: m["identifier"] == "playback" and not m["paused"], start=start)
    assert playing["rate"] == 2.0
    await client.wait_for(lambda m: m["identifier"] == "playback" and m["position"] > 1.0, timeout=10, start=start)
    assert any(record.at(p)[0] > 0.5 for p in _poses(client, start)), "playing again from the start"
    await client.close()


async def test_motion_is_refused_in_a_replay(replay: RunningRelay) -> None:
    client = await TestClient.open(replay.ws_url)
    await client.hello()
    commands: list[dict[str, Any]] = [
        {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0},
        {"identifier": "robot1/goal_pose", "x": 3.0, "y": 2.0},
        {"identifier": "robot3/arm/pose", "name": "home"},
        {"identifier": "robot1/cancel"},
        {"identifier": "mission/start", "robot": "robot1", "steps": [{"goto": {"x": 3.0, "y": 1.5}}]},
    ]
    for command in commands:
        reply = await client.request(command)
        assert reply["identifier"] == "error", command
        assert reply["code"] == "recording", reply
        assert "replayed session (drive.mcap); nothing reaches a robot" in reply["message"]
    assert (await client.request({"identifier": "estop"}))["identifier"] == "ack", "a stop is always taken"
    await client.close()


def _garbage(path: Path, _: Path) -> str:
    path.write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
    return "not an MCAP file, or a truncated one"


def _truncated(path: Path, session: Path) -> str:
    data = session.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3])
    return "not an MCAP file, or a truncated one"


def _foreign(path: Path, _: Path) -> str:
    with path.open("wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="someone-else")
        schema = writer.register_schema("std_msgs/String", "jsonschema", b"{}")
        channel = writer.register_channel("/chatter", "json", schema)
        writer.add_message(channel, 1, b'{"data": "hi"}', 1)
        writer.finish()  # type: ignore[no-untyped-call]
    return "an MCAP, but not a station session (xr-relay --record-session writes those)"


@pytest.mark.parametrize("make", [_garbage, _truncated, _foreign], ids=["garbage", "truncated", "foreign"])
def test_a_file_that_is_not_a_session_is_refused_naming_it(
    make: Any, session: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bad = tmp_path / "bad.mcap"
    reason = make(bad, session)
    before = bad.read_bytes()
    status = main(
        [
            "replay", str(bad), "--config", str(ROOT / "robots.yaml"), "--port", "0", "--no-accounts",
            "--audit-log", "", "--database", str(tmp_path / "db.sqlite"),
        ]
    )  # fmt: skip
    assert status == 2
    assert f"{bad}: cannot replay this session: {reason}" in caplog.text
    assert "Traceback" not in caplog.text
    assert bad.read_bytes() == before, "the file is left as it was"


@pytest.mark.parametrize(
    ("change", "says"),
    [
        ({"head": {"position": [2e4, 0.0, 1.6], "look": [1.0, 0.0, 0.0]}}, "head.position must be [x, y, z]"),
        ({"head": {"position": [0.0, 0.0, 1.6]}}, "head must be an object of position, look"),
        ({"hands": [_viewer(0)["hands"][0]] * 2}, "hands[1].hand must be 'left' or 'right', each once"),
        ({"hands": [{**_viewer(0)["hands"][0], "ray": [0.0, 0.0, 0.0]}]}, "hands[0].ray must be a unit vector"),
        ({"hands": [{"hand": "left"}] * 3}, "hands must be a list of at most 2 hands"),
    ],
)
def test_a_viewer_is_checked_field_by_field(change: dict[str, Any], says: str) -> None:
    parse_command(orjson.dumps(_viewer(3)), ("robot1",))
    with pytest.raises(ProtocolError, match=re.escape(f"viewer: {says}")):
        parse_command(orjson.dumps({**_viewer(3), **change}), ("robot1",))
