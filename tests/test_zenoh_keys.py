"""rmw_zenoh's key expressions and attachment, the fleet's keys, and robots.yaml's zenoh section: pure, pinned bytes."""

from __future__ import annotations

import json
import math
import threading
from typing import Any

import hypothesis.strategies as st
import orjson
import pytest
from hypothesis import HealthCheck, given
from hypothesis import settings as hypothesis_settings

from relay.backends.zenoh_keys import (
    MAX_HEARTBEAT_LEASES,
    PEER_NAME,
    Attachment,
    FleetEstop,
    FleetHeartbeat,
    chunk,
    dds_type,
    decode_attachment,
    decode_estop,
    decode_heartbeat,
    key_type,
    lease_key,
    parse_lease_key,
    ros_type,
    topic_key,
    topic_selector,
)
from relay.backends.zenoh_session import DEFAULT_ROUTER, settings
from relay.cli.options import ZenohOptions
from relay.config import Zenoh, parse_config
from relay.errors import ConfigError


def test_topic_keys_are_rmw_zenohs_and_the_bridges() -> None:
    assert dds_type("nav_msgs/msg/Odometry") == "nav_msgs::msg::dds_::Odometry_"
    assert ros_type("nav_msgs::msg::dds_::Odometry_") == "nav_msgs/msg/Odometry"
    assert ros_type("Odometry") is None
    key = topic_key("rmw_zenoh", 3, "/robot1/odom", "nav_msgs/msg/Odometry", "RIHS01_ab")
    assert key == "3/robot1/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_ab"
    assert topic_selector("rmw_zenoh", 3, "/robot1/odom") == "3/robot1/odom/*/*"
    assert key_type("rmw_zenoh", key) == "nav_msgs/msg/Odometry"
    assert key_type("rmw_zenoh", "3/robot1/odom/weird/RIHS01_ab") == "weird"
    # zenoh-bridge-ros2dds: the topic alone, no type in the key.
    assert topic_key("bridge", 3, "/robot1/odom", "nav_msgs/msg/Odometry", "x") == "robot1/odom"
    assert topic_selector("bridge", 3, "/robot1/odom") == "robot1/odom"
    assert key_type("bridge", "robot1/odom") is None


def test_the_attachment_is_33_bytes_as_rmw_zenoh_serializes_it() -> None:
    attachment = Attachment(sequence=2, timestamp_ns=0x0102030405060708, gid=bytes(range(16)))
    encoded = attachment.encode()
    assert encoded == (
        b"\x02\x00\x00\x00\x00\x00\x00\x00" + b"\x08\x07\x06\x05\x04\x03\x02\x01" + b"\x10" + bytes(range(16))
    )
    assert decode_attachment(encoded) == attachment
    with pytest.raises(ValueError, match="33 bytes, not 32"):
        decode_attachment(encoded[:-1])
    with pytest.raises(ValueError, match="GID is 16 bytes, not 15"):
        decode_attachment(encoded[:16] + b"\x0f" + bytes(16))


def test_lease_keys_carry_robot_relay_and_client_as_safe_chunks() -> None:
    assert chunk("op/1*") == "op_1_" and chunk("") == "_"
    key = lease_key("xr_relay", "robot1", "site-a", "c1-ab/x")
    assert key == "xr_relay/lease/robot1/site-a/c1-ab_x"
    assert parse_lease_key("xr_relay", key) == ("robot1", "site-a", "c1-ab_x")
    with pytest.raises(ValueError, match=r"<robot>/<relay>/<client>, got xr_relay/lease/robot1/site-a$"):
        parse_lease_key("xr_relay", "xr_relay/lease/robot1/site-a")
    with pytest.raises(ValueError, match="<robot>/<relay>/<client>"):
        parse_lease_key("xr_relay", "other/lease/a/b/c")
    with pytest.raises(ValueError, match="<robot>/<relay>/<client>"):
        parse_lease_key("xr_relay", "xr_relay/lease/a/b/c/d")
    with pytest.raises(ValueError, match=r'its relay must be a name of 1 to 64 .*, got "x{36}\.\.\.$'):
        parse_lease_key("xr_relay", "xr_relay/lease/robot1/" + "x" * 200_000 + "/c1")
    with pytest.raises(ValueError, match="its robot must be a robot's name"):
        parse_lease_key("xr_relay", "xr_relay/lease/9lives/site-a/c1")


def test_fleet_estops_round_trip_and_bad_ones_are_named() -> None:
    estop = FleetEstop("site-a", "robot2", "c1")
    assert decode_estop(estop.encode()) == estop
    assert decode_estop(FleetEstop("site-a", None, None).encode()).robot is None
    with pytest.raises(ValueError, match="not JSON"):
        decode_estop(b"\xff")
    with pytest.raises(ValueError, match="names its relay"):
        decode_estop(b'{"robot": "robot1"}')
    with pytest.raises(ValueError, match="robot is a name or null"):
        decode_estop(b'{"relay": "a", "robot": 5}')
    with pytest.raises(ValueError, match="by is an operator of 1 to 64 characters or null, got -1"):
        decode_estop(b'{"relay": "a", "by": -1}')
    with pytest.raises(ValueError, match="at most 1024 bytes, got 400033"):
        decode_estop(orjson.dumps({"relay": "x" * 200_000, "robot": None, "by": "x" * 200_000}))
    # This relay's own estop reaches the others whoever made it: a name they would refuse goes as null.
    assert decode_estop(FleetEstop("site-a", "robot1", "x" * 65).encode()) == FleetEstop("site-a", "robot1", None)
    assert decode_estop(FleetEstop("site-a", None, "op\n1").encode()).by is None


def test_fleet_heartbeats_round_trip_and_name_the_relay_of_their_key() -> None:
    beat = FleetHeartbeat("site-a", {"robot1": "c1-ab", "robot2": "c2-cd"})
    assert decode_heartbeat("xr_relay", "xr_relay/heartbeat/site-a", beat.encode()) == beat
    with pytest.raises(ValueError, match="heartbeat of relay site-a goes on xr_relay/heartbeat/site-a, got xr_relay/h"):
        decode_heartbeat("xr_relay", "xr_relay/heartbeat/site-b", beat.encode())
    with pytest.raises(ValueError, match=f"map up to {MAX_HEARTBEAT_LEASES} robots to clients, got a JSON array"):
        decode_heartbeat("xr_relay", "xr_relay/heartbeat/a", b'{"relay": "a", "leases": []}')


# -- hostile values for every decoder of what other relays send (the fuzz suite's part for Zenoh peers) ------------

HOSTILE_STRINGS = st.sampled_from(
    [
        "",
        "robot1\n",
        "c1\n",
        "R\r\nforged line",
        "x" * 200_000,
        "a/b",
        "*",
        "robot1\u202e",
        "<b>",
        "\x00",
        "c 1",
        "-1",
        "NaN",
    ]
)
hostile_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(2**63), max_value=2**64 - 1)
    | st.floats(allow_nan=False)
    | st.text(max_size=80)
    | HOSTILE_STRINGS,
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=10), children, max_size=4),
    max_leaves=12,
)
#: Samples shaped like the fleet's, a field at a time wrong, and raw bytes (JSON that is not, NaN, deep nesting).
fleet_objects = st.fixed_dictionaries(
    {},
    optional={
        "relay": st.sampled_from(["R", "site-a"]) | hostile_values,
        "robot": st.sampled_from(["robot1", None]) | hostile_values,
        "by": st.sampled_from(["c1-ab", None]) | hostile_values,
        "leases": st.dictionaries(st.sampled_from(["robot1", "robot2"]) | st.text(max_size=70), hostile_values)
        | hostile_values,
    },
)


def as_bytes(value: Any) -> bytes:
    return json.dumps(value, allow_nan=True).encode()  # json, not orjson: NaN and ints past 64 bits reach the decoder


raw_samples = (
    fleet_objects.map(as_bytes)
    | st.binary(max_size=200)
    | st.sampled_from([b"NaN", b'{"relay": NaN}', b"[" * 5000, b"[" * 300 + b"]" * 300, b'{"relay": "R"' * 100])
)


def check_refusal(exc: ValueError) -> None:
    """Named, and short whatever the sample held (relay/session/protocol.py's clipping)."""
    assert str(exc) and len(str(exc)) <= 400, str(exc)


@hypothesis_settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(raw_samples)
def test_a_fleet_estop_is_well_formed_or_refused_in_a_short_line(data: bytes) -> None:
    try:
        estop = decode_estop(data)
    except ValueError as exc:
        check_refusal(exc)
        return
    assert PEER_NAME.fullmatch(estop.relay)
    assert estop.robot is None or (isinstance(estop.robot, str) and len(estop.robot) <= 64)
    assert estop.by is None or (isinstance(estop.by, str) and 0 < len(estop.by) <= 64 and estop.by.isprintable())
    assert estop.robot is None or estop.robot.isprintable()


@hypothesis_settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(raw_samples, st.sampled_from(["xr_relay/heartbeat/R", "xr_relay/heartbeat/site-a", "x" * 300]))
def test_a_fleet_heartbeat_is_well_formed_or_refused_in_a_short_line(data: bytes, key: str) -> None:
    try:
        beat = decode_heartbeat("xr_relay", key, data)
    except ValueError as exc:
        check_refusal(exc)
        return
    assert PEER_NAME.fullmatch(beat.relay) and key == f"xr_relay/heartbeat/{beat.relay}"
    assert len(beat.leases) <= MAX_HEARTBEAT_LEASES
    for robot, client in beat.leases.items():
        assert isinstance(robot, str) and len(robot) <= 64 and PEER_NAME.fullmatch(client)


@hypothesis_settings(max_examples=1000, deadline=None)
@given(st.lists(st.text(max_size=70) | HOSTILE_STRINGS, min_size=0, max_size=5))
def test_a_lease_token_key_is_well_formed_or_refused_in_a_short_line(parts: list[str]) -> None:
    key = "/".join(["xr_relay", "lease", *parts])
    try:
        robot, relay, client = parse_lease_key("xr_relay", key)
    except ValueError as exc:
        check_refusal(exc)
        return
    assert f"{robot}/{relay}/{client}" == "/".join(parts)
    assert all(len(p) <= 64 and p.isprintable() for p in (robot, relay, client))


def test_json_numbers_the_decoders_never_let_through() -> None:
    for value in (math.nan, math.inf, -1, 1.5e308, 2**70, "c1\n", "c1\nforged line"):
        with pytest.raises(ValueError):
            decode_estop(as_bytes({"relay": "R", "by": value}))
        with pytest.raises(ValueError):
            decode_heartbeat("xr_relay", "xr_relay/heartbeat/R", as_bytes({"relay": "R", "leases": {"robot1": value}}))
    assert decode_estop(orjson.dumps({"relay": "R"})) == FleetEstop("R", None, None)


FLEET = "robots:\n  - name: alpha\n    pose: odom\n    limits: {linear: 0.5, angular: 1.0}\n"


def test_the_zenoh_section_and_the_command_line_on_top() -> None:
    config = parse_config(
        FLEET + "zenoh:\n  connect: [tcp/10.0.0.5:7447]\n  mode: peer\n  keys: bridge\n  domain_id: 7\n"
        "  fleet_key: site/fleet\n  relay_id: ops-1\n  config: z.json5\n",
        "fleet.yaml",
    )
    assert config.zenoh == Zenoh(("tcp/10.0.0.5:7447",), "peer", "z.json5", "bridge", 7, "site/fleet", "ops-1")
    s = settings(config.zenoh, ZenohOptions(connect=("tcp/10.0.0.6:7447",), mode="client", relay_id="ops-2"))
    assert (s.connect, s.mode, s.keys, s.domain, s.relay_id) == (("tcp/10.0.0.6:7447",), "client", "bridge", 7, "ops-2")
    assert settings(Zenoh(), ZenohOptions()).connect == (DEFAULT_ROUTER,)


@pytest.mark.parametrize(
    ("section", "expected"),
    [
        ("{mode: router}", "zenoh.mode: expected one of client, peer"),
        ("{keys: dds}", "zenoh.keys: expected one of rmw_zenoh, bridge"),
        ("{domain_id: 300}", "zenoh.domain_id: expected a ROS domain id 0-232"),
        ("{fleet_key: 'a/*'}", "zenoh.fleet_key: expected a Zenoh key"),
        ("{relay_id: 'a/b'}", "zenoh.relay_id: expected a name of 1 to 64 letters, digits, _ . or -"),
        ("{relay_id: " + "r" * 65 + "}", "zenoh.relay_id: expected a name of 1 to 64"),
        ("{peer_lease_timeout: 1}", "zenoh.peer_lease_timeout: expected at least 3 s (relays heartbeat every second)"),
        ("{peer_lease_timeout: .nan}", "zenoh.peer_lease_timeout: expected a positive number"),
        ("{connect: tcp/x:1}", "zenoh.connect"),
        ("{routers: []}", "routers"),
    ],
)
def test_a_bad_zenoh_section_is_named(section: str, expected: str) -> None:
    with pytest.raises(ConfigError, match=r"fleet\.yaml") as info:
        parse_config(FLEET + f"zenoh: {section}\n", "fleet.yaml")
    assert expected in str(info.value)


def test_a_relay_id_the_others_would_refuse_stops_the_relay_at_start() -> None:
    from relay.backends.zenoh_fleet import ZenohFleet
    from relay.errors import BackendUnavailable

    assert ZenohFleet("xr_relay", "ops 1", lambda call: None, ["alpha"]).relay_id == "ops_1"
    with pytest.raises(BackendUnavailable, match=r"--relay-id \(zenoh.relay_id\) is 1 to 64 letters"):
        ZenohFleet("xr_relay", "r" * 65, lambda call: None, ["alpha"])


class _Entity:
    """A declared publisher, subscriber or token of the fake session: who undeclared it, from which thread."""

    def __init__(self, key: str, log: list[tuple[str, str, str]]) -> None:
        self.key, self.log = key, log

    def put(self, payload: bytes) -> None:
        self.log.append(("put", self.key, threading.current_thread().name))

    def undeclare(self) -> None:
        self.log.append(("undeclare", self.key, threading.current_thread().name))


class _SlowSession:
    """Zenoh's session as ZenohFleet uses it; declaring a token waits (Zenoh's runtime busy, as on a loaded
    machine) until the test lets it go."""

    def __init__(self) -> None:
        self.log: list[tuple[str, str, str]] = []
        self.release = threading.Event()

    def zid(self) -> str:
        return "fake"

    def declare_publisher(self, key: str, **_: Any) -> _Entity:
        return _Entity(key, self.log)

    def declare_subscriber(self, key: str, *_: Any, **__: Any) -> _Entity:
        return _Entity(key, self.log)

    def liveliness(self) -> _SlowSession:
        return self

    def declare_token(self, key: str) -> _Entity:
        self.release.wait(10)
        self.log.append(("token", key, threading.current_thread().name))
        return _Entity(key, self.log)


def test_a_lease_change_never_waits_on_zenoh_on_the_loop_and_its_tokens_follow_in_order() -> None:
    """Declaring and withdrawing a lease's token wait on Zenoh's runtime: they run on the fleet's token thread, in
    the order the leases changed, while the heartbeat (a put that drops under congestion) says so at once."""
    from types import SimpleNamespace

    from relay.backends.zenoh_fleet import ZenohFleet

    zenoh = SimpleNamespace(
        CongestionControl=SimpleNamespace(BLOCK=0, DROP=1), Priority=SimpleNamespace(REAL_TIME=0), SampleKind=None
    )
    session = _SlowSession()
    fleet = ZenohFleet("xr_relay", "ops", lambda call: None, ["alpha"])
    fleet.open(zenoh, session)
    fleet.lease_changed("alpha", "c1")  # returns with the token still waiting on the session
    fleet.lease_changed("alpha", "c2")
    fleet.lease_changed("alpha", None)
    loop_thread = threading.current_thread().name
    assert [entry[0] for entry in session.log if entry[0] != "put"] == []
    assert sum(entry[0] == "put" for entry in session.log) >= 4  # open's beat and one a change, at once
    session.release.set()
    fleet._token_worker.submit(lambda: None).result(10)  # the token thread has done what was asked before
    tokens = [(kind, key.rsplit("/", 2)[-1]) for kind, key, _ in session.log if kind != "put"]
    assert tokens == [("token", "c1"), ("undeclare", "c1"), ("token", "c2"), ("undeclare", "c2")]
    assert all(thread != loop_thread for kind, _, thread in session.log if kind != "put")
