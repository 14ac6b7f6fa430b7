"""The schema once: every message typed in Python, and the browser's types generated from those types.

Each command's wire form (what a client sends, from the command's one declaration) must say what ``parse_command``
accepts: a frame with every field accepted, one missing a required field refused. Every server message builder
must return exactly the keys of its TypedDict, so the browser's generated typedefs never drift from what the relay
sends. Every example message of docs/protocol.md has exactly its TypedDict's keys, and the committed browser module
is what the generator writes today.
"""

from __future__ import annotations

import importlib
import json
import re
import sys
import typing
from pathlib import Path
from typing import Any, get_type_hints, is_typeddict

import pytest

from relay.arm import wire as arm_wire
from relay.errors import ProtocolError
from relay.fleet.events import ValveEvent
from relay.inspection import messages as inspection_messages
from relay.session import protocol
from relay.sim import valve_wire
from relay.station import messages
from relay.study import wire as study_wire
from relay.wire import messages as station_messages
from relay.wire import viewer
from relay.wire.declare import WireForm, wire_forms

ROOT = Path(__file__).resolve().parent.parent
ROBOTS = ("robot1",)

#: A valid value for each field name (the parser checks ranges; these are inside them).
SAMPLES: dict[str, Any] = {"id": "r1", "x": 1.0, "y": 2.0, "yaw": 0.5, "linear": 0.1, "angular": 0.0,
                           "camera": "front", "fps": 10.0, "action": "acquire", "force": True, "robot": "robot1",
                           "t": 3.0, "rate": 2.0, "file": "demo", "steps": [{"inspect": "spill"}],
                           "targets": ["spill"], "name": "Valves", "mission": "m-1.robot1", "capture": "c-1",
                           "finding": "f-1", "status": "anomaly", "note": "rust", "u": 5, "v": 6,
                           "region": [[0, 0], [10, 0], [10, 10]], "target": "valve-1", "kind": "valve",
                           "facing": 0.5, "codec": "h264", "before": 1795388500.25, "limit": 20,
                           "alert": "a-20261122-230140-3f9a21c07b5e44d8", "schedule": "nightly",
                           "start": 1795388400.0, "repeat": 3600, "windows": [{"days": ["mon"], "hours": [8, 17]}],
                           "blackouts": [{"start": 1795400000, "end": 1795403600}], "priority": 1,
                           "on_busy": "skip", "robots": ["robot1"], "frame": "tip", "state": "open",
                           "position": 0.01, "participant": "P01", "questionnaire": "tlx",
                           "answers": [50, 40, 30, 60, 55, 20], "probe": "corridor",
                           "head": {"position": [1.0, 2.0, 1.6], "look": [1.0, 0.0, 0.0]},
                           "hands": [{"hand": "right", "position": [1.2, 1.8, 1.1], "ray": [0.0, 0.6, -0.8]}],
                           "view": "top",
                           }  # fmt: skip
#: A schedule's ``mission`` is mission/start's form, where mission/* commands name a mission by id.
SCHEDULE_SAMPLES: dict[str, Any] = {**SAMPLES, "mission": {"targets": ["spill"]}}
#: An arm's twist is two vectors, where cmd_vel's linear and angular are numbers.
ARM_SAMPLES: dict[str, Any] = {**SAMPLES, "linear": [0.05, 0.0, 0.0], "angular": [0.0, 0.0, 0.2]}


def _forms() -> list[tuple[str, WireForm]]:
    """Each wire form of each declared command, with each identifier it arrives as (robot1's for robot-scoped ones)."""
    found = []
    for cls in protocol.COMMANDS.commands:
        for form in wire_forms(cls, f"{cls.__name__}Command"):
            kind = cls.IDENTIFIERS[0].partition("/")[2]
            found += [(identifier or f"robot1/{kind}", form) for identifier in form.identifiers]
    return found


FORMS = _forms()


@pytest.mark.parametrize(("identifier", "form"), FORMS, ids=lambda v: getattr(v, "name", ""))
def test_each_commands_wire_form_is_what_the_parser_accepts(identifier: str, form: WireForm) -> None:
    required = [key for key, _, needed in form.fields if needed]
    optional = [key for key, _, needed in form.fields if not needed]
    samples = {**SAMPLES, "action": "reset"} if identifier == "estop" else SAMPLES
    samples = SCHEDULE_SAMPLES if identifier.startswith("schedule/") else samples
    samples = ARM_SAMPLES if identifier.startswith("robot1/arm/") else samples
    full = {"identifier": identifier, **{k: samples[k] for k in required + optional}}
    protocol.parse_command(protocol_bytes(full), ROBOTS)
    protocol.parse_command(protocol_bytes({"identifier": identifier, **{k: samples[k] for k in required}}), ROBOTS)
    for missing in required:
        frame = {k: v for k, v in full.items() if k != missing}
        with pytest.raises(ProtocolError, match=missing):
            protocol.parse_command(protocol_bytes(frame), ROBOTS)


def test_every_client_kind_has_a_wire_form() -> None:
    kinds = {identifier.removeprefix("robot1/") for identifier, _ in FORMS}
    assert kinds == set(protocol.CLIENT_ROBOT_KINDS) | set(protocol.CLIENT_GLOBAL_KINDS)


BUILT: list[tuple[type, Any]] = [
    (messages.AckMessage, messages.ack_message("a")),
    (messages.ErrorMessage, messages.error_message(None, "bad_request", "why")),
    (messages.PongMessage, messages.pong_message(1.0, 2.0)),
    (messages.BackendMessage, messages.backend_message("sim", None)),
    (messages.ModelMessage, messages.model_message("robot1", "/m.glb")),
    (messages.SceneMessage, messages.scene_message(None, {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0})),
    (
        messages.PlaybackMessage,
        messages.playback_message(position=1.0, duration=2.0, rate=1.0, paused=False, loop=True),
    ),
    (messages.LeaseMessage, messages.lease_message("robot1", holder="c1", previous=None, reason="acquired")),
    (messages.EstopMessage, messages.estop_message(["robot1"], "c1")),
    (
        messages.StatusMessage,
        messages.status_message("robot1", online=True, age=0.1, mode="idle", goal=None, controller=None),
    ),
    (
        messages.SensorMessage,
        messages.sensor_message("robot1", name="gas", value=1.0, unit="ppm", warning=False, stamp=1.0),
    ),
    (study_wire.StudyMessage, study_wire.study_message(study="s", phase="waiting", participants=["P01"])),
    (
        messages.AvatarMessage,
        messages.avatar_message("c1", "Ana", 1.0, ((1.0, 2.0, 1.6), (1.0, 0.0, 0.0)), [("left", (1, 2, 1), (0, 1, 0))]),
    ),
    (
        messages.VoxelMapMessage,
        messages.voxel_map_message(version=3, since=0, reset=True, voxel=0.05, blocks=2, frames=1),
    ),
    (valve_wire.ValveMessage, valve_wire.valve_message(ValveEvent(15.6, 7.25, 0.2, -1.5708, 0.05, 0.0, False, False))),
]


@pytest.mark.parametrize(("cls", "message"), BUILT, ids=lambda v: getattr(v, "__name__", ""))
def test_each_builder_returns_exactly_its_typeddicts_keys(cls: type, message: dict[str, Any]) -> None:
    assert list(message) == list(get_type_hints(cls))


def test_every_server_message_is_in_the_union_and_in_the_generated_file() -> None:
    union = {t.__name__ for t in typing.get_args(messages.ServerMessage)}
    declared = {
        name
        for module in (station_messages, inspection_messages, arm_wire, study_wire, viewer, valve_wire)
        for name, value in vars(module).items()
        if name.endswith("Message") and is_typeddict(value) and value.__module__ == module.__name__
    }
    assert union == declared and len(union) == 30
    generated = _generator().render()
    for name in union | {form.name for _, form in FORMS}:
        assert f"}} {name} */" in generated, name
    assert "@typedef {" + " | ".join(t.__name__ for t in typing.get_args(messages.ServerMessage)) in generated


def _generator() -> Any:
    sys.path.insert(0, str(ROOT / "tools"))
    return importlib.import_module("gen_protocol_js")


def test_generated_browser_protocol_is_current() -> None:
    committed = (ROOT / "xr_client/src/protocol.js").read_text()
    assert committed == _generator().render(), "xr_client/src/protocol.js is stale: run python tools/gen_protocol_js.py"


def test_each_state_message_knows_its_coalescing_key() -> None:
    """Each sensor keeps its own newest reading; every other state message one per identifier."""
    gas = messages.sensor_message("robot1", name="gas", value=1.0, unit="ppm", warning=False, stamp=1.0)
    assert messages.state_key(gas) == protocol.sensor_key("robot1", "gas") == "robot1/sensor/gas"
    pose = messages.pose_message("robot1", stamp=1.0, frame="map", x=0, y=0, z=0, qx=0, qy=0, qz=0, qw=1)
    status = messages.status_message("robot2", online=True, age=None, mode="idle", goal=None, controller=None)
    scene = messages.scene_message(None, {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0})
    playback = messages.playback_message(position=1.0, duration=2.0, rate=1.0, paused=False, loop=True)
    nav = messages.nav_message("robot1", outcome="reached", goal=None, message="")
    path = messages.path_message("robot1", [(0.0, 0.0)])
    for message in (pose, status, scene, playback, nav, path):
        assert messages.state_key(message) == message["identifier"]
    union = {t.__name__ for t in typing.get_args(messages.StateMessage)}
    assert union == {
        "PoseMessage",
        "SensorMessage",
        "StatusMessage",
        "ScanMessage",
        "NavMessage",
        "PathMessage",
        "SceneMessage",
        "PlaybackMessage",
    }


# -- docs/protocol.md, the contract, against the types --------------------------------------------------------

DOC = (ROOT / "docs/protocol.md").read_text()


def _doc_examples() -> list[dict[str, Any]]:
    """Every JSON object in the doc that has an identifier (inline or in a code block)."""
    decoder = json.JSONDecoder()
    return [decoder.raw_decode(DOC, m.start())[0] for m in re.finditer(r'\{"identifier"', DOC)]


def _server_type(identifier: str) -> type:
    kind = identifier if identifier in protocol.SERVER_GLOBAL_KINDS else identifier.partition("/")[2]
    if kind.startswith("camera/"):
        return messages.FrameHeader
    name = "".join(part.capitalize() for part in kind.split("_")) + "Message"
    cls: type = (
        getattr(station_messages, name, None)
        or getattr(inspection_messages, name, None)
        or getattr(arm_wire, name, None)
        or getattr(study_wire, name, None)
        or getattr(viewer, name, None)
        or getattr(valve_wire, name)
    )
    return cls


def test_each_example_of_the_doc_has_exactly_its_typeddicts_keys_in_order() -> None:
    examples = _doc_examples()
    for example in examples:
        hints = get_type_hints(_server_type(example["identifier"]), include_extras=True)
        # NotRequired keys (a video frame's keyframe and codec) may be left out, never reordered.
        optional = {k for k, t in hints.items() if typing.get_origin(t) is typing.NotRequired}
        assert list(example) == [k for k in hints if k not in optional or k in example], example
    documented = {_server_type(e["identifier"]) for e in examples}
    assert documented == {messages.FrameHeader, *typing.get_args(messages.ServerMessage)} - {messages.HelloMessage}


def _table_column(heading: str) -> list[str]:
    """The backticked names of a table's first column, from the table under ``heading``."""
    table = DOC[DOC.index(heading) :].split("\n\n")[0]
    return [name for row in re.findall(r"^\| (`[^|]+`) \|", table, re.M) for name in re.findall(r"`([^`]+)`", row)]


def test_the_docs_tables_name_every_field_code_and_command() -> None:
    assert set(_table_column("| field | type | meaning |")) == set(get_type_hints(messages.HelloMessage))
    assert _table_column("| code | when |") == list(protocol.ErrorCode.ALL)
    commands = {f"<robot>/{kind}" for kind in protocol.CLIENT_ROBOT_KINDS} | set(protocol.CLIENT_GLOBAL_KINDS)
    assert set(_table_column("| identifier | fields | effect |")) == commands


def protocol_bytes(message: dict[str, Any]) -> bytes:
    return messages.encode(message)


def _shape(value: Any) -> Any:
    """Keys and value kinds, not values: what a client's code depends on."""
    if isinstance(value, dict):
        return {k: _shape(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_shape(value[0])] if value else []
    return type(value).__name__ if value is not None else None


async def test_the_clients_hello_fixture_has_the_shape_the_relay_sends(fleet_config: Any) -> None:
    """xr_client/test/fixtures/hello.json drives the router's node tests: it must stay what the relay sends."""
    from relay.fleet.events import PoseEvent
    from relay.station.core import Relay
    from relay.twin.facility import load_facility

    class Quiet:
        async def send_text(self, data: bytes) -> None: ...
        async def send_binary(self, data: bytes) -> None: ...
        async def close(self, code: int, reason: str) -> None: ...

    relay = Relay(fleet_config)
    relay.rooms = messages.room_descriptions(load_facility(ROOT / "scenes/facility.yaml").rooms)  # as start() does
    pose = PoseEvent(robot="robot1", stamp=1.0, frame="map", x=3.0, y=1.5, z=0.0, qx=0.0, qy=0.0, qz=0.7, qw=0.7)
    relay.on_event(pose)
    client = relay.connect(Quiet())
    try:
        hello = json.loads(messages.encode(relay.hello(client)))
    finally:
        await relay.hub.remove(client.channel)
    fixture = json.loads((ROOT / "xr_client/test/fixtures/hello.json").read_text())
    assert _shape(fixture) == _shape(hello)
