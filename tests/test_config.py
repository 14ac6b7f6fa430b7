"""robots.yaml: the demo file loads, defaults follow the namespace convention, and every error names
the file, the line and the field."""

from __future__ import annotations

import logging
import textwrap
from pathlib import Path

import pytest

from relay.backends import dds_profile
from relay.cli.main import main
from relay.config import SpillGrowth, load_config, parse_config
from relay.errors import ConfigError

ROOT = Path(__file__).resolve().parent.parent

MINIMAL = """\
robots:
  - name: alpha
    limits: {linear: 0.5, angular: 1.0}
"""


def error_of(text: str) -> str:
    with pytest.raises(ConfigError) as info:
        parse_config(textwrap.dedent(text), "robots.yaml")
    return str(info.value)


def test_demo_fleet_loads() -> None:
    config = load_config(ROOT / "robots.yaml")
    assert config.names == ("robot1", "robot2", "robot3")
    robot1 = config.robots[0]
    assert robot1.limits.linear > 0 and robot1.limits.angular > 0
    assert {s.name for s in robot1.sensors} == {"gas", "temperature", "humidity"}
    gas = robot1.sensors[0]
    assert gas.topic == "/robot1/gas" and gas.warn_above == 400
    assert config.sim.world == ROOT / "scenes" / "facility.yaml"  # hazards and walls come from the scene
    assert len({r.colour for r in config.robots}) == 3


def test_the_site_has_a_name_and_a_time_zone_the_zone_database_knows() -> None:
    config = parse_config(MINIMAL + "site: {name: North plant, time_zone: Europe/Berlin}\n")
    assert (config.site.name, config.site.time_zone) == ("North plant", "Europe/Berlin")
    assert (parse_config(MINIMAL).site.name, parse_config(MINIMAL).site.time_zone) == (None, None)
    assert error_of(MINIMAL + "site: {time_zone: Mars/Olympus}\n").startswith(
        "robots.yaml:4: site.time_zone: no time zone 'Mars/Olympus': expected an IANA name such as Europe/Berlin"
    )
    assert error_of(MINIMAL + f"site: {{name: {'x' * 201}}}\n").startswith(
        "robots.yaml:4: site.name: expected at most 200 characters, got 201"
    )
    assert "site.city: unknown field" in error_of(MINIMAL + "site: {city: Bremen}\n")


def test_topic_defaults_follow_namespace() -> None:
    robot = parse_config(MINIMAL).robots[0]
    assert robot.namespace == "/alpha"
    assert robot.pose.source == "odom" and robot.pose.topic == "/alpha/odom"
    assert robot.cmd_vel_topic == "/alpha/cmd_vel"
    assert robot.goal_topic == "/alpha/goal_pose"


def test_topic_overrides_and_root_namespace() -> None:
    config = parse_config(
        textwrap.dedent(
            """\
            robots:
              - name: tb3
                namespace: ""
                pose: {source: tf, base_frame: base_link}
                cmd_vel: {topic: /mux/cmd_vel, stamped: true}
                cameras:
                  - {name: front, compressed: true, lens: {model: equisolid, fov: 190}, width: 1280, height: 720}
                sensors:
                  - {name: battery, type: sensor_msgs/msg/BatteryState, topic: battery_state, warn_below: 20}
                limits: {linear: 0.26, angular: 1.82}
            """
        )
    )
    robot = config.robots[0]
    assert robot.namespace == ""
    assert robot.pose.topic == "/tf" and robot.pose.base_frame == "base_link"
    assert robot.cmd_vel_topic == "/mux/cmd_vel" and robot.cmd_vel_stamped
    assert robot.goal_topic == "/goal_pose"
    camera = robot.cameras[0]
    assert camera.topic == "/camera/image_raw/compressed" and camera.lens.fov == 190
    sensor = robot.sensors[0]
    assert sensor.topic == "/battery_state" and sensor.unit == "%"
    assert sensor.is_warning(10) and not sensor.is_warning(50)


def test_navigation_defaults_to_nav2_in_the_namespace_and_every_key_can_be_set() -> None:
    robot = parse_config(MINIMAL).robots[0]
    assert robot.nav_interface == "nav2" and robot.nav_action == "/alpha/navigate_to_pose"
    assert robot.autonomy_topic == "/alpha/cmd_vel_nav" and robot.on_relay_lost == "hold"
    assert robot.gate_topic == "/alpha/xr_relay/gate"
    assert robot.gate_state_topic == "/alpha/xr_relay/gate_state"
    text = (
        "robots:\n  - name: tb3\n    namespace: ''\n    limits: {linear: 0.2, angular: 1}\n"
        "    navigation: {interface: topic, action: /nav/navigate, autonomy: cmd_vel_monitored, "
        "on_relay_lost: continue}\n"
    )
    robot = parse_config(text).robots[0]
    assert (robot.nav_interface, robot.nav_action, robot.autonomy_topic, robot.on_relay_lost) == (
        "topic",
        "/nav/navigate",
        "/cmd_vel_monitored",
        "continue",
    )
    assert (robot.gate_topic, robot.gate_state_topic) == ("/xr_relay/gate", "/xr_relay/gate_state")


def test_navigation_defaults_to_nav2_beside_the_namespace_and_every_key_can_be_set() -> None:
    robot = parse_config(MINIMAL).robots[0]
    assert (robot.nav_interface, robot.nav_action, robot.autonomy_topic, robot.on_relay_lost) == (
        "nav2", "/alpha/navigate_to_pose", "/alpha/cmd_vel_nav", "hold",
    )  # fmt: skip
    assert (robot.gate_topic, robot.gate_state_topic) == ("/alpha/xr_relay/gate", "/alpha/xr_relay/gate_state")
    text = (
        "robots:\n"
        "  - {name: a, namespace: '', limits: {linear: 1, angular: 1}, navigation: topic}\n"
        "  - name: b\n    limits: {linear: 1, angular: 1}\n"
        "    navigation: {action: /nav/navigate_to_pose, autonomy: controller/cmd_vel, on_relay_lost: continue}\n"
    )
    a, b = parse_config(text).robots
    assert (a.nav_interface, a.nav_action, a.gate_topic, a.gate_state_topic) == (
        "topic", "/navigate_to_pose", "/xr_relay/gate", "/xr_relay/gate_state",
    )  # fmt: skip
    assert (b.nav_interface, b.nav_action, b.autonomy_topic, b.on_relay_lost) == (
        "nav2", "/nav/navigate_to_pose", "/b/controller/cmd_vel", "continue",
    )  # fmt: skip


def test_a_robot_is_in_the_team_robots_yaml_names_or_in_none() -> None:
    text = (
        "robots:\n  - {name: a, team: North crew, limits: {linear: 1, angular: 1}}\n"
        "  - {name: b, limits: {linear: 1, angular: 1}}\n"
    )
    assert [(r.name, r.team) for r in parse_config(text).robots] == [("a", "North crew"), ("b", None)]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            """\
            robots:
              - name: a
                limits: {linear: 0.5, angular: 1}
              - name: b
                limits:
                  linear: fast
                  angular: 1
            """,
            'robots.yaml:6: robots[1].limits.linear: expected a positive number, got "fast"',
        ),
        (
            """\
            robots:
              - name: a
                limits: {linear: -1, angular: 1}
            """,
            "robots.yaml:3: robots[0].limits.linear: expected a positive number, got -1",
        ),
        (
            """\
            robots:
              - name: a
                colr: red
                limits: {linear: 1, angular: 1}
            """,
            "robots.yaml:3: robots[0].colr: unknown field; expected one of name, namespace, colour",
        ),
        (
            "sim: {scan_rate: 40}\nrobots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n",
            "robots.yaml:1: sim.scan_rate: at most 10 Hz (the relay sends no more scans), got 40",
        ),
        ("scene: {}\n", "robots.yaml:1: robots: is required"),
        ("robots: []\n", "robots.yaml:1: robots: expected at least one robot"),
        ("robots: {a: 1}\n", "robots.yaml:1: robots: expected a list, got a mapping"),
        ("robots:\n  - name: a\n", "robots.yaml:2: robots[0].limits: is required"),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n"
            "  - name: a\n    limits: {linear: 1, angular: 1}\n",
            'robots.yaml:4: robots[1].name: duplicate robot name "a"',
        ),
        (
            "robots:\n  - name: 9lives\n    limits: {linear: 1, angular: 1}\n",
            'robots.yaml:2: robots[0].name: expected a name of letters, digits and _, got "9lives"',
        ),
        (
            "robots:\n  - name: a\n    colour: blue\n    limits: {linear: 1, angular: 1}\n",
            'robots.yaml:3: robots[0].colour: expected a colour like #e6194b, got "blue"',
        ),
        (
            "robots:\n  - name: a\n    team: north/east\n    limits: {linear: 1, angular: 1}\n",
            'robots.yaml:3: robots[0].team: expected a team name of 1-32 letters, digits, spaces, _ and -, got "north/',
        ),
        (
            "robots:\n  - name: a\n    pose: gps\n    limits: {linear: 1, angular: 1}\n",
            'robots.yaml:3: robots[0].pose: expected one of tf, odom, amcl_pose, pose, got "gps"',
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    sensors:\n"
            "      - {name: gas, type: std_msgs/String}\n",
            "robots.yaml:5: robots[0].sensors[0].type: expected one of std_msgs/Float32",
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    sensors:\n"
            "      - {name: t, type: std_msgs/Float32, warn_above: 10, warn_below: 20}\n",
            "robots.yaml:5: robots[0].sensors[0].warn_below: must be below warn_above (10)",
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    cameras:\n"
            "      - {name: front, lens: {model: opencv_fisheye}}\n",
            "robots.yaml:5: robots[0].cameras[0].lens: opencv_fisheye needs K (9 numbers) and D (4 numbers)",
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    cameras:\n"
            "      - {name: front}\n      - {name: rear}\n",
            "robots.yaml:6: robots[0].cameras[1].topic: topic /a/camera/image_raw is already used",
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    cmd_vel: {topic: 'bad topic!'}\n",
            "robots.yaml:4: robots[0].cmd_vel.topic: expected a ROS topic name",
        ),
        ("robots:\n  - name: a\n    limits: {linear: 1, angular: [\n", "robots.yaml:4: not valid YAML"),
        ("", "robots.yaml: the file is empty"),
        (
            MINIMAL + "sim: {world: nowhere/facility.yaml}\n",
            "robots.yaml:4: sim.world: no such file: nowhere/facility.yaml",
        ),
        (
            MINIMAL + "safety: {deadman_timeout: 0}\n",
            "robots.yaml:4: safety.deadman_timeout: expected a positive number, got 0",
        ),
        (
            MINIMAL + "sim:\n  hazards:\n    - {kind: gas, x: 1}\n",
            "robots.yaml:6: sim.hazards[0].y: is required",
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    navigation: {interface: action}\n",
            'robots.yaml:4: robots[0].navigation.interface: expected one of nav2, topic, got "action"',
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    navigation: {on_relay_lost: stop}\n",
            'robots.yaml:4: robots[0].navigation.on_relay_lost: expected one of hold, continue, got "stop"',
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    navigation: {action: 'no way'}\n",
            "robots.yaml:4: robots[0].navigation.action: expected a ROS topic name",
        ),
        (
            "robots:\n  - name: a\n    limits: {linear: 1, angular: 1}\n    navigation: {acton: x}\n",
            "robots.yaml:4: robots[0].navigation",
        ),
        (
            MINIMAL + "ros: {executor: multi}\n",
            'robots.yaml:4: ros.executor: expected one of events, single, got "multi"',
        ),
        (
            MINIMAL + "ros: {dds_profile: nowhere/fastdds.xml}\n",
            "robots.yaml:4: ros.dds_profile: no Fast DDS profile file at nowhere/fastdds.xml",
        ),
        (
            MINIMAL + "    navigation: {interface: action}\n",
            'robots.yaml:4: robots[0].navigation.interface: expected one of nav2, topic, got "action"',
        ),
        (
            MINIMAL + "    navigation: {on_relay_lost: stop}\n",
            'robots.yaml:4: robots[0].navigation.on_relay_lost: expected one of hold, continue, got "stop"',
        ),
        (
            MINIMAL + "    navigation: {autonomy: 'cmd vel'}\n",
            "robots.yaml:4: robots[0].navigation.autonomy: expected a ROS topic name such as /robot1/odom, "
            'got "cmd vel"',
        ),
        (
            MINIMAL + "    navigation: {action: 12}\n",
            "robots.yaml:4: robots[0].navigation.action: expected a ROS topic name such as /robot1/odom, got 12",
        ),
        (
            MINIMAL + "    navigation: {autonomy: cmd_vel}\n",
            "robots.yaml:4: robots[0].navigation.autonomy: expected a topic other than cmd_vel's and teleop's, "
            "got /alpha/cmd_vel",
        ),
        (
            MINIMAL + "    cmd_vel: {watchdog: true}\n    navigation: {autonomy: /alpha/xr_relay/cmd_vel}\n",
            "robots.yaml:5: robots[0].navigation.autonomy: expected a topic other than cmd_vel's and teleop's",
        ),
        (
            MINIMAL + "    cmd_vel: {topic: cmd_vel_nav}\n",
            "robots.yaml:4: robots[0].navigation.autonomy: expected a topic other than cmd_vel's and teleop's, "
            "got /alpha/cmd_vel_nav",
        ),
        (  # the short form names the interface: only nav2 or topic
            MINIMAL + "    navigation: ros2\n",
            'robots.yaml:4: robots[0].navigation.interface: expected one of nav2, topic, got "ros2"',
        ),
        (
            MINIMAL + "    navigation: {controller: cmd_vel_nav}\n",
            "robots.yaml:4: robots[0].navigation.controller: unknown field; expected one of interface, action, "
            "autonomy, on_relay_lost",
        ),
    ],
)
def test_errors_name_file_line_and_field(text: str, expected: str) -> None:
    assert error_of(text).startswith(expected)


@pytest.mark.parametrize(
    ("growth", "expected"),
    [
        ("{rate: -0.1}", "robots.yaml:5: sim.spill_growth.rate: expected a number >= 0, got -0.1"),
        ("{rate: fast}", 'robots.yaml:5: sim.spill_growth.rate: expected a number >= 0, got "fast"'),
        ("{rate: .nan}", "robots.yaml:5: sim.spill_growth.rate: expected a number >= 0"),
        (
            "{limit: 0.5}",
            "robots.yaml:5: sim.spill_growth.limit: expected a number >= 1 (times the first size), got 0.5",
        ),
        ("{limit: .inf}", "robots.yaml:5: sim.spill_growth.limit: expected a number"),
        ("{speed: 1}", "robots.yaml:5: sim.spill_growth.speed: unknown field; expected one of rate, limit"),
        ("0.1", "robots.yaml:5: sim.spill_growth: expected a mapping"),
    ],
)
def test_bad_spill_growth_is_an_error_naming_the_key(tmp_path: Path, growth: str, expected: str) -> None:
    good = MINIMAL + "sim:\n  spill_growth: {rate: 0.1, limit: 2}\n"
    assert parse_config(good).sim.spill_growth == SpillGrowth(0.1, 2.0)
    assert parse_config(MINIMAL).sim.spill_growth == SpillGrowth(0.0, 2.0)  # no growth unless asked
    assert error_of(MINIMAL + f"sim:\n  spill_growth: {growth}\n").startswith(expected)
    # Nothing changes: a relay started on the bad file exits 2 before building any world, and the file is as it was.
    bad = tmp_path / "fleet.yaml"
    bad.write_text(MINIMAL + f"sim:\n  spill_growth: {growth}\n")
    before = bad.read_bytes()
    with pytest.raises(ConfigError) as info:
        load_config(bad)
    assert "sim.spill_growth" in str(info.value) and bad.read_bytes() == before


def test_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path / "missing.yaml")
    assert "missing.yaml" in str(info.value) and "cannot read" in str(info.value)


def test_relay_exits_2_on_bad_config(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    bad = tmp_path / "fleet.yaml"
    bad.write_text("robots:\n  - name: a\n    limits: {linear: fast, angular: 1}\n")
    with caplog.at_level(logging.ERROR):
        status = main(["--config", str(bad), "--port", "0"])
    assert status == 2
    assert f'{bad}:3: robots[0].limits.linear: expected a positive number, got "fast"' in caplog.text


def test_the_dds_profile_is_the_relays_unless_the_environment_or_the_config_names_another(tmp_path: Path) -> None:
    assert parse_config(MINIMAL).ros.dds_profile == "large_images"
    mine = tmp_path / "site.xml"
    mine.write_text("<dds/>")
    (tmp_path / "robots.yaml").write_text(MINIMAL + "ros: {dds_profile: site.xml}\n")
    assert load_config(tmp_path / "robots.yaml").ros.dds_profile == str(mine), "relative to the config file"
    environ: dict[str, str] = {}
    assert dds_profile.apply("large_images", environ) == str(dds_profile.LARGE_IMAGES)
    assert environ["FASTDDS_DEFAULT_PROFILES_FILE"] == str(dds_profile.LARGE_IMAGES)
    assert "<segment_size>" in dds_profile.LARGE_IMAGES.read_text(), "the shipped profile is there"
    theirs = {"FASTRTPS_DEFAULT_PROFILES_FILE": "/etc/robot/fastdds.xml"}
    assert dds_profile.apply("large_images", theirs) == "FASTRTPS_DEFAULT_PROFILES_FILE=/etc/robot/fastdds.xml"
    assert "FASTDDS_DEFAULT_PROFILES_FILE" not in theirs, "the operator's choice wins"
    builtin: dict[str, str] = {}
    assert dds_profile.apply("builtin", builtin) == "builtin" and builtin == {}


WEBHOOKS = MINIMAL + "inspection:\n  webhooks:\n"


@pytest.mark.parametrize(
    ("entry", "expected"),
    [
        (
            "    - {url: 'ftp://alerts.example/in', secret: 'a-long-enough-secret'}\n",
            "robots.yaml:6: inspection.webhooks[0].url: expected an http:// or https:// URL, got a ftp: URL",
        ),
        (
            "    - {url: 'alerts.example/in', secret: 'a-long-enough-secret'}\n",
            "robots.yaml:6: inspection.webhooks[0].url: expected an http:// or https:// URL, got no scheme",
        ),
        (
            "    - {url: 'https:///in', secret: 'a-long-enough-secret'}\n",
            "robots.yaml:6: inspection.webhooks[0].url: expected an http:// or https:// URL with a host",
        ),
        (
            "    - {url: 'https://alerts.example/in'}\n",
            "robots.yaml:6: inspection.webhooks[0]: give exactly one of secret (the shared secret) or secret_env",
        ),
        (
            "    - {url: 'https://alerts.example/in', secret: 'short-one'}\n",
            "robots.yaml:6: inspection.webhooks[0].secret: expected a secret of at least 16 characters (not shown",
        ),
        (
            "    - {url: 'https://alerts.example/in', secret_env: XR_RELAY_TEST_UNSET}\n",
            "robots.yaml:6: inspection.webhooks[0].secret_env: the environment variable XR_RELAY_TEST_UNSET is not set",
        ),
        (
            "    - {url: 'https://alerts.example/in', secret: 'a-long-enough-secret', events: [anomaly, fire]}\n",
            "robots.yaml:6: inspection.webhooks[0].events[1]: expected one of anomaly, changed, threshold, "
            'mission_aborted, schedule_missed, schedule_failed, alert.acknowledged, got "fire"',
        ),
    ],
)
def test_a_bad_webhook_is_a_clear_error_that_never_shows_its_secret(entry: str, expected: str) -> None:
    message = error_of(WEBHOOKS + entry)
    assert message.startswith(expected), message
    assert "short-one" not in message and "a-long-enough-secret" not in message


def test_webhooks_read_their_secret_from_the_file_or_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XR_RELAY_HOOK_SECRET", "from-the-environment-0123")
    config = parse_config(
        WEBHOOKS
        + "    - {url: 'https://alerts.example/in', secret_env: XR_RELAY_HOOK_SECRET, events: [alert.acknowledged]}\n"
        + "    - {url: 'http://127.0.0.1:8088/hook', secret: 'in-the-file-0123456'}\n"
    )
    first, second = config.inspection.webhooks
    assert (first.url, first.secret, first.events) == (
        "https://alerts.example/in", "from-the-environment-0123", ("alert.acknowledged",),
    )  # fmt: skip
    assert (second.url, second.secret, second.events) == ("http://127.0.0.1:8088/hook", "in-the-file-0123456", None)
    assert "from-the-environment" not in repr(config) and "in-the-file" not in repr(config)
    assert parse_config(MINIMAL).inspection.webhooks == ()
