"""rmw_zenoh's key expressions and attachment, the fleet's keys, and robots.yaml's zenoh section: pure, pinned bytes."""

from __future__ import annotations

import pytest

from relay.backends.zenoh_keys import (
    Attachment,
    FleetEstop,
    chunk,
    dds_type,
    decode_attachment,
    decode_estop,
    key_type,
    lease_key,
    parse_lease_key,
    ros_type,
    topic_key,
    topic_selector,
)
from relay.backends.zenoh_session import DEFAULT_ROUTER, settings
from relay.config import Zenoh, parse_config
from relay.errors import ConfigError
from relay.options import ZenohOptions


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
    assert parse_lease_key("xr_relay", "xr_relay/lease/robot1/site-a") is None
    assert parse_lease_key("xr_relay", "other/lease/a/b/c") is None


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
        ("{relay_id: 'a/b'}", "zenoh.relay_id: expected a key chunk"),
        ("{connect: tcp/x:1}", "zenoh.connect"),
        ("{routers: []}", "routers"),
    ],
)
def test_a_bad_zenoh_section_is_named(section: str, expected: str) -> None:
    with pytest.raises(ConfigError, match=r"fleet\.yaml") as info:
        parse_config(FLEET + f"zenoh: {section}\n", "fleet.yaml")
    assert expected in str(info.value)
