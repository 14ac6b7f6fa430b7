"""Protocol v1 without sockets: the exact bytes of every message kind, and every error path."""

from __future__ import annotations

import dataclasses
import math

import pytest

from relay.errors import ProtocolError
from relay.session.protocol import MAX_TEXT_BYTES, parse_command
from relay.station.messages import (
    MAX_PATH_POINTS,
    FrameHeader,
    NavFeedback,
    ack_message,
    backend_message,
    decode_frame,
    encode,
    encode_frame,
    error_message,
    estop_message,
    lease_message,
    model_message,
    nav_message,
    operators_message,
    path_message,
    playback_message,
    pong_message,
    pose_message,
    scan_message,
    scene_message,
    sensor_message,
    status_message,
)
from relay.wire.commands import Cancel, CmdVel, EStop, GoalPose, Name, Ping, Playback, Snapshot, Stream

ROBOTS = ("robot1", "robot2")


# -- encoded form of every server message (the bytes are the contract of docs/protocol.md) ----------


def test_pose_bytes() -> None:
    msg = pose_message(
        "robot1",
        stamp=1700000000.1234567,
        frame="map",
        x=1.23456,
        y=-2.0,
        z=0.0,
        qx=0.0,
        qy=0.0,
        qz=math.sin(0.25),
        qw=math.cos(0.25),
    )
    assert encode(msg) == (
        b'{"identifier":"robot1/pose","stamp":1700000000.123457,"frame":"map","x":1.2346,"y":-2.0,"z":0.0,'
        b'"qx":0.0,"qy":0.0,"qz":0.247404,"qw":0.968912,"yaw":0.5}'
    )


def test_sensor_bytes() -> None:
    msg = sensor_message("robot1", name="gas", value=512.345678, unit="ppm", warning=True, stamp=12.5)
    assert encode(msg) == (
        b'{"identifier":"robot1/sensor","name":"gas","value":512.3457,"unit":"ppm","warning":true,"stamp":12.5}'
    )


def test_status_bytes() -> None:
    msg = status_message(
        "robot2",
        online=True,
        age=0.01234,
        mode="navigating",
        goal={"x": 3.0, "y": 6.0, "yaw": None},
        controller="c1-abc",
    )
    assert encode(msg) == (
        b'{"identifier":"robot2/status","online":true,"age":0.012,"mode":"navigating",'
        b'"goal":{"x":3.0,"y":6.0,"yaw":null},"controller":"c1-abc","estopped":false}'
    )
    latched = status_message("robot2", online=True, age=None, mode="idle", goal=None, controller=None, estopped=True)
    assert encode(latched).endswith(b'"controller":null,"estopped":true}')
    idle = status_message("robot3", online=False, age=None, mode="idle", goal=None, controller=None)
    assert encode(idle) == (
        b'{"identifier":"robot3/status","online":false,"age":null,"mode":"idle","goal":null,"controller":null,"estopped":false}'
    )


def test_ack_error_pong_estop_bytes() -> None:
    assert encode(ack_message("g1")) == b'{"identifier":"ack","id":"g1"}'
    assert encode(error_message(7, "unknown_robot", "no such robot")) == (
        b'{"identifier":"error","id":7,"code":"unknown_robot","message":"no such robot"}'
    )
    assert encode(error_message(None, "bad_request", "x")) == (
        b'{"identifier":"error","id":null,"code":"bad_request","message":"x"}'
    )
    assert encode(pong_message(12.5, 1000.0000004)) == b'{"identifier":"pong","t":12.5,"server_time":1000.0}'
    assert encode(estop_message(["robot1"], "c1")) == (
        b'{"identifier":"estop","robots":["robot1"],"by":"c1","latched":true}'
    )
    assert encode(estop_message(["robot1", "robot2"], "c2", latched=False)) == (
        b'{"identifier":"estop","robots":["robot1","robot2"],"by":"c2","latched":false}'
    )


def test_scan_scene_playback_bytes() -> None:
    scan = scan_message(
        "robot1", stamp=2.0, frame="base_scan", angle_min=-math.pi, angle_increment=math.pi / 2,
        range_max=8.0, ranges=(1.234, float("inf"), float("nan"), 7.999),
    )  # fmt: skip
    assert encode(scan) == (
        b'{"identifier":"robot1/scan","stamp":2.0,"frame":"base_scan","angle_min":-3.141593,'
        b'"angle_increment":1.570796,"range_max":8.0,"ranges":[1.23,null,null,8.0]}'
    )
    scene = scene_message("/scenes/generated/m.glb", {"x": 1.0, "y": 0.0, "z": 0.0, "yaw": 0.5})
    assert encode(scene) == (
        b'{"identifier":"scene","url":"/scenes/generated/m.glb","map_to_scene":{"x":1.0,"y":0.0,"z":0.0,"yaw":0.5}}'
    )
    playback = playback_message(position=12.34567, duration=27.6, rate=1.0, paused=False, loop=True)
    assert encode(playback) == (
        b'{"identifier":"playback","position":12.346,"duration":27.6,"rate":1.0,"paused":false,"loop":true}'
    )


def test_nav_and_path_bytes() -> None:
    reached = nav_message("robot1", outcome="reached", goal={"x": 9.0, "y": 6.0, "yaw": None}, message="")
    assert encode(reached) == (
        b'{"identifier":"robot1/nav","outcome":"reached","goal":{"x":9.0,"y":6.0,"yaw":null},"message":"",'
        b'"error_code":null,"feedback":null,"confirmed":null}'
    )
    failed = nav_message("robot2", outcome="failed", goal=None, message="blocked for 30 s", error_code=105)
    assert encode(failed) == (
        b'{"identifier":"robot2/nav","outcome":"failed","goal":null,"message":"blocked for 30 s",'
        b'"error_code":105,"feedback":null,"confirmed":null}'
    )
    feedback = NavFeedback(distance_remaining=3.24999, eta=7.46, recoveries=1, navigation_time=12.26)
    running = nav_message("robot1", outcome="started", goal=None, message="", feedback=feedback)
    assert encode(running) == (
        b'{"identifier":"robot1/nav","outcome":"started","goal":null,"message":"","error_code":null,'
        b'"feedback":{"distance_remaining":3.25,"eta":7.5,"recoveries":1,"navigation_time":12.3},"confirmed":null}'
    )
    answered = nav_message(
        "robot1", outcome="cancelled", goal=None, message="Nav2 is cancelling 1 goal", confirmed=True
    )
    assert encode(answered).endswith(b'"message":"Nav2 is cancelling 1 goal","error_code":null,"feedback":null,'
                                     b'"confirmed":true}')  # fmt: skip
    assert encode(path_message("robot1", [(3.0, 1.5), (8.7751, 2.3249), (9.0, 6.0)])) == (
        b'{"identifier":"robot1/path","points":[[3.0,1.5],[8.78,2.32],[9.0,6.0]]}'
    )
    assert encode(path_message("robot1", [])) == b'{"identifier":"robot1/path","points":[]}'
    # A planner's thousands of points are thinned evenly to MAX_PATH_POINTS, keeping both ends.
    long = path_message("robot1", [(i * 0.01, 0.0) for i in range(5001)])
    assert (
        len(long["points"]) == MAX_PATH_POINTS and long["points"][0] == [0.0, 0.0] and long["points"][-1] == [50.0, 0.0]
    )


def test_operators_bytes_and_the_name_rule() -> None:
    assert encode(operators_message({"c2-77b01e": "Ben", "c1-3f2a9c": "Zoë O'Neil"})) == (
        '{"identifier":"operators","names":{"c1-3f2a9c":"Zoë O\'Neil","c2-77b01e":"Ben"}}'.encode()
    )
    assert parse_command('{"identifier":"name","id":1,"name":"  Ana   Lopez "}', ROBOTS) == Name(id=1, name="Ana Lopez")
    for bad in ('"<b>Ana</b>"', '""', '"   "', '"' + "a" * 41 + '"', '"Ops (night)"', "7", '"\\u0007bell"'):
        with pytest.raises(ProtocolError) as info:
            parse_command('{"identifier":"name","id":2,"name":' + bad + "}", ROBOTS)
        assert info.value.code == "bad_request" and info.value.request_id == 2, bad


def test_lease_model_backend_bytes() -> None:
    lease = lease_message("robot1", holder="c2-ab12cd", previous="c1-9f3e21", reason="taken_over")
    assert encode(lease) == (
        b'{"identifier":"robot1/lease","holder":"c2-ab12cd","previous":"c1-9f3e21","reason":"taken_over"}'
    )
    released = lease_message("robot1", holder=None, previous="c1-9f3e21", reason="released")
    assert encode(released) == (
        b'{"identifier":"robot1/lease","holder":null,"previous":"c1-9f3e21","reason":"released"}'
    )
    model = model_message("robot1", "/scenes/generated/robot-robot1-3f2a9c.glb")
    assert encode(model) == b'{"identifier":"robot1/model","url":"/scenes/generated/robot-robot1-3f2a9c.glb"}'
    failed = backend_message("ros", "the ROS executor stopped")
    assert encode(failed) == (b'{"identifier":"backend","name":"ros","ok":false,"message":"the ROS executor stopped"}')
    assert encode(backend_message("ros", None)) == b'{"identifier":"backend","name":"ros","ok":true,"message":null}'


def test_binary_frame_layout() -> None:
    header: FrameHeader = {
        "identifier": "robot1/camera/front",
        "seq": 3,
        "stamp": 1.5,
        "encoding": "jpeg",
        "width": 640,
        "height": 480,
        "lens": {"model": "equidistant", "fov": 180.0},
        "request_id": None,
    }
    payload = b"\xff\xd8jpeg-bytes\xff\xd9"
    data = encode_frame(header, payload)
    head = (
        b'{"identifier":"robot1/camera/front","seq":3,"stamp":1.5,"encoding":"jpeg","width":640,'
        b'"height":480,"lens":{"model":"equidistant","fov":180.0},"request_id":null}'
    )
    assert data == len(head).to_bytes(4, "big") + head + payload
    decoded, body = decode_frame(data)
    assert decoded == header and body == payload


def test_h264_frame_header_bytes() -> None:
    """The header the relay puts on a video packet (relay/media/streams.py), pinned: what the browser's decoder
    reads."""
    from relay.config import parse_config
    from relay.fleet.events import FrameEvent
    from relay.fleet.state import FleetState
    from relay.media.streams import CameraStreams
    from relay.media.video import Packet
    from relay.station.hub import Hub
    from relay.station.outbox import Outbox

    config = parse_config(
        "robots:\n  - name: robot1\n    limits: {linear: 0.5, angular: 1.0}\n"
        "    cameras: [{name: front, width: 640, height: 480}]\n",
        "robots.yaml",
    )
    hub = Hub()
    sent: list[bytes] = []

    def publish_video(identifier: str, data: bytes, keyframe: bool) -> tuple[int, int]:
        sent.append(data)
        return 1, 0

    hub.publish_video = publish_video  # type: ignore[method-assign]
    robots = {r.name: r for r in config.robots}
    streams = CameraStreams(robots, hub, Outbox(hub, FleetState(config, 1.0)), backend=None)  # type: ignore[arg-type]
    frame = FrameEvent("robot1", "front", 1.5, 640, 480, b"")
    streams._publish_video("robot1/camera/front", frame, Packet(b"\x00\x00\x00\x01\x65", True, "avc1.42C01E", 640, 480))
    head = (
        b'{"identifier":"robot1/camera/front","seq":1,"stamp":1.5,"encoding":"h264","width":640,"height":480,'
        b'"lens":{"model":"equidistant","fov":180.0},"request_id":null,"keyframe":true,"codec":"avc1.42C01E"}'
    )
    assert sent == [len(head).to_bytes(4, "big") + head + b"\x00\x00\x00\x01\x65"]
    streams.close()


@pytest.mark.parametrize("data", [b"", b"\x00\x00\x00\x10{}", b"\x00\x00\x00\x02[]"])
def test_bad_binary_frames(data: bytes) -> None:
    with pytest.raises(ProtocolError):
        decode_frame(data)


# -- parsing client commands ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('{"identifier":"robot1/goal_pose","id":"g","x":1,"y":2.5}', GoalPose("robot1", "g", 1.0, 2.5, None)),
        ('{"identifier":"robot1/goal_pose","id":3,"x":1,"y":2,"yaw":-1.5}', GoalPose("robot1", 3, 1.0, 2.0, -1.5)),
        ('{"identifier":"robot2/cmd_vel","linear":0.2,"angular":-0.1}', CmdVel("robot2", 0.2, -0.1, None)),
        ('{"identifier":"robot2/cmd_vel","linear":0,"angular":0,"id":"v"}', CmdVel("robot2", 0.0, 0.0, "v")),
        ('{"identifier":"robot1/cancel","id":"c"}', Cancel("robot1", "c")),
        ('{"identifier":"robot1/snapshot","id":"s"}', Snapshot("robot1", "s", None)),
        ('{"identifier":"robot1/snapshot","id":"s","camera":"front"}', Snapshot("robot1", "s", "front")),
        ('{"identifier":"robot1/stream","id":"s","camera":"front","fps":15}', Stream("robot1", "s", "front", 15.0)),
        ('{"identifier":"estop","id":"e"}', EStop("e", None)),
        ('{"identifier":"estop","id":"e","robot":"robot2"}', EStop("e", "robot2")),
        ('{"identifier":"estop","id":"e","action":"reset"}', EStop("e", None, "reset")),
        ('{"identifier":"ping","t":123.25}', Ping(123.25)),
        ('{"identifier":"playback/pause","id":"p"}', Playback("p", "pause", None)),
        ('{"identifier":"playback/seek","id":"p","t":12.5}', Playback("p", "seek", 12.5)),
        ('{"identifier":"playback/rate","id":"p","rate":2}', Playback("p", "rate", 2.0)),
        ('{"identifier":"robot1/cancel","id":"c","future_field":[1,2]}', Cancel("robot1", "c")),
    ],
)
def test_parse_commands(text: str, expected: object) -> None:
    assert parse_command(text, ROBOTS) == expected
    assert parse_command(text.encode(), ROBOTS) == expected


@pytest.mark.parametrize(
    ("text", "code", "request_id", "words"),
    [
        ("not json", "bad_request", None, "not valid JSON"),
        ("[1, 2]", "bad_request", None, "JSON object"),
        ('"hello"', "bad_request", None, "JSON object"),
        ('{"id": "a"}', "bad_request", "a", "no 'identifier'"),
        ('{"identifier": 5, "id": "a"}', "bad_request", "a", "'identifier' must be a string"),
        ('{"identifier": "robot1/fly", "id": "a"}', "unknown_identifier", "a", "robot1/fly"),
        ('{"identifier": "launch", "id": "a"}', "unknown_identifier", "a", "launch"),
        ('{"identifier": "robot9/goal_pose", "id": "a", "x": 1, "y": 1}', "unknown_robot", "a", "robot9"),
        ('{"identifier": "robot1/goal_pose", "id": "a", "x": 1}', "bad_request", "a", "missing field 'y'"),
        ('{"identifier": "robot1/goal_pose", "x": 1, "y": 2}', "bad_request", None, "missing field 'id'"),
        ('{"identifier": "robot1/goal_pose", "id": "a", "x": "1", "y": 2}', "bad_request", "a", "'x' must be a number"),
        (
            '{"identifier": "robot1/goal_pose", "id": "a", "x": true, "y": 2}',
            "bad_request",
            "a",
            "'x' must be a number",
        ),
        ('{"identifier": "robot1/goal_pose", "id": "a", "x": 1e999, "y": 2}', "bad_request", None, "infinity"),
        ('{"identifier": "robot1/goal_pose", "id": "a", "x": NaN, "y": 2}', "bad_request", None, "not valid JSON"),
        ('{"identifier": "robot1/cmd_vel", "linear": null, "angular": 0}', "bad_request", None, "'linear'"),
        ('{"identifier": "robot1/cmd_vel", "linear": [1], "angular": 0, "id": 4}', "bad_request", 4, "'linear'"),
        ('{"identifier": "robot1/stream", "id": "a", "camera": "front", "fps": 500}', "bad_request", "a", "between"),
        ('{"identifier": "robot1/stream", "id": "a", "fps": 5}', "bad_request", "a", "'camera'"),
        ('{"identifier": "robot1/snapshot", "id": "a", "camera": 7}', "bad_request", "a", "'camera'"),
        ('{"identifier": "estop", "id": "a", "robot": "robot7"}', "unknown_robot", "a", "robot7"),
        ('{"identifier": "estop"}', "bad_request", None, "'id'"),
        ('{"identifier": "estop", "id": "r", "action": "release"}', "bad_request", "r", "'stop' or 'reset'"),
        ('{"identifier": "ping"}', "bad_request", None, "'t'"),
        ('{"identifier": "playback/seek", "id": "a", "t": -1}', "bad_request", "a", "between"),
        ('{"identifier": "playback/rate", "id": "a", "rate": 100}', "bad_request", "a", "between"),
        ('{"identifier": "playback/stop", "id": "a"}', "unknown_identifier", "a", "playback/stop"),
        ('{"identifier": "robot1/cancel", "id": {"a": 1}}', "bad_request", None, "'id' must be"),
        ('{"identifier": "robot1/cancel", "id": ""}', "bad_request", None, "'id' must be"),
        ('{"identifier": "robot1/cancel", "id": 9007199254740993}', "bad_request", None, "2**53"),
    ],
)
def test_parse_errors(text: str, code: str, request_id: object, words: str) -> None:
    with pytest.raises(ProtocolError) as info:
        parse_command(text, ROBOTS)
    assert info.value.code == code
    assert info.value.request_id == request_id
    assert words in info.value.message


def test_too_large_frame() -> None:
    text = '{"identifier":"ping","t":1,"pad":"' + "x" * MAX_TEXT_BYTES + '"}'
    with pytest.raises(ProtocolError) as info:
        parse_command(text, ROBOTS)
    assert info.value.code == "too_large"
    assert str(MAX_TEXT_BYTES) in info.value.message


def test_bad_value_is_not_echoed_in_full() -> None:
    with pytest.raises(ProtocolError) as info:
        parse_command('{"identifier":"robot1/goal_pose","id":"a","x":"' + "z" * 5000 + '","y":1}', ROBOTS)
    assert len(info.value.message) < 200


def test_inspection_messages_are_pinned() -> None:
    from relay.inspection.messages import (
        finding_message,
        mission_message,
        region_message,
        targets_changed_message,
        targets_message,
    )
    from relay.inspection.records import FindingRecord, MissionRecord, ReadingTrend, Step, Target

    assert encode(targets_message([Target("spill", "Spill", "gas", 1.8, 8.2)])) == (
        b'{"identifier":"targets","targets":[{"id":"spill","name":"Spill","kind":"gas","x":1.8,"y":8.2,"facing":null}]}'
    )
    assert encode(targets_changed_message([Target("valve-12", "Valve 12", "valve", 15.6, 7.6)])) == (
        b'{"identifier":"targets_changed","added":[{"id":"valve-12","name":"Valve 12","kind":"valve","x":15.6,"y":7.6,'
        b'"facing":null}],"removed":[]}'
    )
    mission = MissionRecord("m-1.robot1", "Demo", "robot1", (Step("dwell", seconds=2.0),), "paused", 0, "c2", 1.0, 2.5)
    assert encode(mission_message(mission)) == (
        b'{"identifier":"mission","id":"m-1.robot1","name":"Demo","robot":"robot1","state":"paused","current":0,'
        b'"steps":[{"kind":"dwell","target":null,"x":null,"y":null,"yaw":null,"seconds":2.0}],"reason":"c2",'
        b'"owner":"","updated":2.5}'
    )
    finding = FindingRecord("f-1", "c-1", "robot1", 1.8, 8.2, "anomaly", "gas", "rule", 3.0, 3.0, "m-1.robot1",
                            "spill", ((1, 2), (3, 4), (5, 6)))  # fmt: skip
    assert encode(finding_message(finding, "ab" * 32, {"gas": 698.2})) == (
        b'{"identifier":"finding","id":"f-1","capture":"c-1","mission":"m-1.robot1","target":"spill","robot":"robot1",'
        b'"x":1.8,"y":8.2,"status":"anomaly","note":"gas","source":"rule","region":[[1,2],[3,4],[5,6]],'
        b'"image":"/captures/' + b"ab" * 32 + b'.jpg","readings":{"gas":698.2},"created":3.0,"updated":3.0,'
        b'"change":null,"baseline":null,"before":null,"trend":null}'
    )
    # A change since the last round: its score, the capture it was compared with and that capture's image.
    changed = dataclasses.replace(finding, status="changed", note="2.8 %", change=0.0282, baseline="c-0")
    assert encode(finding_message(changed, "ab" * 32, {}, before="cd" * 32)).endswith(
        b'"status":"changed","note":"2.8 %","source":"rule","region":[[1,2],[3,4],[5,6]],'
        b'"image":"/captures/' + b"ab" * 32 + b'.jpg","readings":{},"created":3.0,"updated":3.0,'
        b'"change":0.0282,"baseline":"c-0","before":"/captures/' + b"cd" * 32 + b'.jpg","trend":null}'
    )
    # A reading heading for its limit: its last rounds as [time, value], its threshold and unit.
    trending = dataclasses.replace(
        finding,
        status="changed",
        trend=ReadingTrend("gas", "ppm", 400.0, ((1795388500.25, 204.5), (1795388560.0, 284.2))),
    )
    assert encode(finding_message(trending, None, {"gas": 284.2})).endswith(
        b'"change":null,"baseline":null,"before":null,"trend":{"sensor":"gas","unit":"ppm","threshold":400.0,'
        b'"points":[[1795388500.25,204.5],[1795388560.0,284.2]]}}'
    )
    assert encode(region_message("r7", "c-1", ((1, 2), (3, 4), (5, 6)))) == (
        b'{"identifier":"region","id":"r7","capture":"c-1","outline":[[1,2],[3,4],[5,6]]}'
    )
