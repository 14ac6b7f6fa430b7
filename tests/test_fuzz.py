"""Bad input, generated: the parser and the live /ws endpoint never crash, answer every bad frame with an
``error``, and let nothing reach a robot. The number of cases each run executes is printed (-s) and logged."""

from __future__ import annotations

import asyncio
import json
import logging
import math
import sys
from pathlib import Path
from typing import Any

import hypothesis.strategies as st
import pytest
from hypothesis import HealthCheck, given, settings

from relay.cli.options import Options
from relay.config import FleetConfig
from relay.errors import ProtocolError
from relay.session.protocol import CLIENT_ROBOT_KINDS, Command, parse_command
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.spy import CommandSpy
from tests.wsclient import TestClient

logger = logging.getLogger(__name__)
ROBOTS = ("robot1", "robot2", "robot3")

json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**70), max_value=2**70)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=40),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=10), children, max_size=4),
    max_leaves=20,
)
identifiers = st.sampled_from(
    [f"{r}/{k}" for r in (*ROBOTS, "robot9", "") for k in (*CLIENT_ROBOT_KINDS, "pose", "fly")]
    + ["estop", "ping", "hello", "ack", "playback/seek", "playback/rate", "", "/", "robot1/"]
) | st.text(max_size=30)
field_names = st.sampled_from(["id", "x", "y", "yaw", "linear", "angular", "camera", "fps", "t", "robot", "rate"])
messages = st.builds(
    lambda identifier, fields: {"identifier": identifier, **fields},
    identifiers,
    st.dictionaries(field_names, json_values, max_size=6),
)


@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=300))
def test_parser_survives_random_bytes(data: bytes) -> None:
    try:
        parse_command(data, ROBOTS)
    except ProtocolError as exc:
        assert exc.code and exc.message


@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(messages)
def test_parser_accepts_only_well_formed_commands(message: dict[str, Any]) -> None:
    text = json.dumps(message)  # json, not orjson: integers beyond 64 bits must reach the parser too
    try:
        command = parse_command(text, ROBOTS)
    except ProtocolError as exc:
        assert exc.code in (
            "bad_request", "unknown_identifier", "unknown_robot", "too_large",
        ), exc.code  # fmt: skip
        return
    check_command(command)


def check_command(command: Command) -> None:
    """Whatever the parser lets through is typed and finite."""
    robot = getattr(command, "robot", None)
    assert robot is None or robot in ROBOTS
    for name in ("x", "y", "yaw", "linear", "angular", "fps", "t", "value"):
        value = getattr(command, name, None)
        if value is not None:
            assert isinstance(value, float) and math.isfinite(value)
    rid = getattr(command, "id", None)
    assert rid is None or (isinstance(rid, str | int) and not isinstance(rid, bool))


async def test_websocket_endpoint_survives_generated_bad_frames() -> None:
    """400 bad frames to /ws: an error for each, nothing reaches a robot, the relay's memory stays flat and the
    connection stays usable. Run in a process of its own (tests/helpers/ws_fuzz_memory.py), which traces its memory
    and exits without stopping the tracer."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "tests.helpers.ws_fuzz_memory", "20261121", "400",
        cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )  # fmt: skip
    try:
        out, err = await asyncio.wait_for(process.communicate(), 300)
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()
    assert process.returncode == 0 and out, err.decode(errors="replace")[-3000:]
    result = json.loads(out.decode().strip().splitlines()[-1])
    logger.info("fuzzed /ws: %s", result)
    print(f"\n/ws fuzz: {result['frames']} bad frames, memory +{result['grown'] / 1e3:.1f} kB")  # noqa: T201
    assert result["not_errors"] == []  # an error for every frame
    assert result["grown"] < 500_000, result["biggest"]  # flat: no per-frame leak (frames of up to 200 kB)
    assert result["moving"] == []  # nothing reached a robot
    assert result["after"] == "ack"  # still usable afterwards


@pytest.mark.parametrize("size", [1024 * 1024 + 1, 3 * 1024 * 1024])
async def test_frames_over_the_socket_limit_close_the_connection(relay_server: RunningRelay, size: int) -> None:
    client = await TestClient.open(relay_server.ws_url)
    await client.hello()
    await client.send_raw("x" * size)
    await asyncio.wait_for(client._reader, 5)
    assert client.closed_code == 1009  # message too big: bounded before it is buffered
    # The relay itself is fine.
    other = await TestClient.open(relay_server.ws_url)
    await other.hello()
    await other.close()


#: One well-formed message of every kind a client may send; the hostile values below replace one field at a time.
EVERY_KIND: dict[str, dict[str, Any]] = {
    "goal_pose": {"identifier": "robot1/goal_pose", "x": 3.0, "y": 6.0, "yaw": 0.5},
    "cmd_vel": {"identifier": "robot1/cmd_vel", "linear": 0.2, "angular": 0.1, "t": 1000.0},
    "cancel": {"identifier": "robot1/cancel"},
    "snapshot": {"identifier": "robot1/snapshot", "camera": "front"},
    "stream": {"identifier": "robot1/stream", "camera": "front", "fps": 5},
    "lease": {"identifier": "robot1/lease", "action": "acquire", "force": False},
    "estop": {"identifier": "estop", "robot": "robot2", "action": "stop"},
    "playback/pause": {"identifier": "playback/pause"},
    "playback/resume": {"identifier": "playback/resume"},
    "playback/seek": {"identifier": "playback/seek", "value": 1.0},
    "playback/rate": {"identifier": "playback/rate", "value": 2.0},
    # Inspection (issue #28): missions, findings, regions and targets, each of their forms.
    "mission/start-file": {"identifier": "mission/start", "file": "demo"},
    "mission/start-steps": {
        "identifier": "mission/start", "robot": "robot1", "steps": [{"goto": {"x": 3.0, "y": 2.5}}], "name": "m",
    },
    "mission/start-targets": {"identifier": "mission/start", "targets": ["spill"], "name": "m"},
    "mission/pause": {"identifier": "mission/pause", "mission": "m-1.robot1"},
    "mission/abort": {"identifier": "mission/abort", "mission": "m-1.robot1"},
    "finding/mark": {
        "identifier": "finding/mark", "capture": "c-1", "status": "anomaly", "note": "n",
        "region": [[1, 2], [3, 4], [5, 6]],
    },
    "finding/update": {"identifier": "finding/update", "finding": "f-1", "status": "ok", "note": "n"},
    "region": {"identifier": "region", "capture": "c-1", "u": 10.0, "v": 20.0},
    "target/add": {"identifier": "target/add", "target": "t1", "x": 3.0, "y": 4.0, "name": "T", "kind": "point"},
    "target/add-pixel": {"identifier": "target/add", "target": "t2", "capture": "c-1", "u": 10.0, "v": 20.0},
    "target/add-live": {"identifier": "target/add", "target": "t3", "robot": "robot1", "u": 240.0, "v": 240.0},
}  # fmt: skip
HOSTILE: list[Any] = [
    "r" * 1000,  # the 1000-character name that once filled the audit log
    "robot1\u0000",
    "\ud800",  # a lone surrogate: valid JSON escape, invalid text
    -1e308,
    1e308,
    2**80,
    -0.0,
    True,
    None,
    [],
    {"$gt": ""},
    "<script>alert(1)</script>",
]


def hostile_frames() -> list[tuple[str, str]]:
    """(kind, frame): every field of every kind (and its id, and its identifier's robot) set to each value."""
    frames: list[tuple[str, str]] = []
    for kind, base in EVERY_KIND.items():
        for field in [*(k for k in base if k != "identifier"), "id"]:
            for value in HOSTILE:
                frames.append((kind, json.dumps({**base, "id": f"{kind}-{len(frames)}", field: value})))
        if base["identifier"].partition("/")[0] == "robot1":  # robot-scoped: a hostile robot name too
            for value in HOSTILE[:3]:
                identifier = f"{value}/{base['identifier'].split('/')[1]}"
                frames.append((kind, json.dumps({**base, "id": f"{kind}-{len(frames)}", "identifier": identifier})))
    return frames


#: The kinds in groups, each group a test of its own: the frames go one at a time (each answer is that frame's), and
#: about 1200 of them in one test took 65 s on a loaded machine; in four groups, parallel workers share them.
KIND_GROUPS = 4


@pytest.mark.parametrize("group", range(KIND_GROUPS))
@pytest.mark.parametrize("role", ["viewer", "operator"])
async def test_every_command_kind_with_hostile_values(
    role: str, group: int, fleet_config: FleetConfig, tmp_path: Path
) -> None:
    audit = tmp_path / "audit.jsonl"
    running = await start_relay(
        fleet_config, options=Options(token="op", allow_viewers=True, audit_log=str(audit), max_message_rate=200)
    )
    spy = CommandSpy(running.relay.backend)  # type: ignore[arg-type]
    client = await TestClient.open(running.ws_url + ("?token=op" if role == "operator" else ""))
    try:
        assert (await client.hello())["role"] == role
        kinds = list(EVERY_KIND)[group::KIND_GROUPS]
        frames = [(kind, frame) for kind, frame in hostile_frames() if kind in kinds]
        outcomes: dict[str, int] = {}
        internal: list[str] = []  # frames the relay failed on: each one a bug
        for kind, frame in frames:
            start = len(client.messages)
            await client.send_raw(frame)
            if kind == "cmd_vel" and json.loads(frame).get("id") is None:
                # The 20 Hz stream is acknowledged only with an id: a ping after it shows whether it was refused.
                await client.send({"identifier": "ping", "t": 42})
                await client.wait_for(lambda m: m["identifier"] == "pong", start=start)
                errors = [m for _, m in client.messages[start:] if m["identifier"] == "error"]
                reply = errors[0] if errors else {"identifier": "ack"}
            else:
                # Frames go one at a time, so the next reply is this frame's (its id may be the hostile value).
                try:
                    # 30 s: a live target renders a snapshot, and a loaded CI machine takes its time.
                    reply = await client.wait_for(lambda m: m["identifier"] in ("ack", "error"), 30, start=start)
                except TimeoutError:
                    raise AssertionError(f"no reply to {frame[:300]}") from None
            key = reply.get("code") or "ack"
            outcomes[key] = outcomes.get(key, 0) + 1
            if key == "internal":
                internal.append(f"{frame[:200]} -> {reply['message']}")
            assert len(reply.get("message") or "") < 400, reply
            await asyncio.sleep(0.006)  # under the rate limit: what is under test is each frame's answer
        print(f"\nhostile values as {role}: {len(frames)} frames, {outcomes}")  # noqa: T201
        assert sum(outcomes.values()) == len(frames)
        if role == "viewer":
            # A viewer may watch (streams, snapshots of existing cameras) and nothing else.
            assert spy.moving_commands() == [] and spy.calls == []
            assert set(outcomes) <= {"ack", "forbidden", "bad_request", "unknown_robot", "no_camera", "busy"}, outcomes
        else:
            for name, args in spy.moving_commands():  # whatever reached a robot is finite and within its limits
                assert all(math.isfinite(a) for a in args[1:] if isinstance(a, float)), (name, args)
                if name == "send_velocity":
                    assert abs(args[1]) <= 0.6 and abs(args[2]) <= 1.8, args
        assert not internal, internal
        # Still connected and answering; the audit log holds short lines only.
        reply = await client.request({"identifier": "robot1/snapshot", "camera": "front"}, timeout=20)
        assert reply["identifier"] in ("ack", "error") and client.closed_code is None
        assert max(len(line) for line in audit.read_text().splitlines()) < 700
    finally:
        await client.close()
        await running.runner.cleanup()
