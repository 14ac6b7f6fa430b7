"""The zenoh backend through a real Zenoh router on 127.0.0.1 (a free port per test) and a real relay with a real
WebSocket client: what a robot under rmw_zenoh publishes reaches the operator field by field, and the operator's
commands reach the robot as rmw_zenoh would send them. tests/zenoh_robots.py is the robots' side.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import struct
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.backends import zenoh as zenoh_backend  # noqa: E402
from relay.backends.zenoh import ZenohBackend  # noqa: E402
from relay.cli.options import Options, ZenohOptions  # noqa: E402
from relay.config import load_config, parse_config  # noqa: E402
from relay.errors import BackendUnavailable  # noqa: E402
from tests.conftest import ROOT, start_relay  # noqa: E402
from tests.helpers.zenoh import FLEET, ODOM, Router, decode, demo_fleet_over_zenoh, fleet, until, zenoh_relay  # noqa: E402
from tests.wsclient import TestClient  # noqa: E402
from tests.zenoh_robots import (  # noqa: E402
    STORE,
    T,
    free_port,
    header,
    key,
    odometry_by_hand,
    odometry_by_rosbags,
    router_config,
)


def test_the_hand_built_odometry_is_the_one_rosbags_serializes() -> None:
    # The independent publisher's bytes are CDR as ROS writes it (frame ids of every alignment).
    for frame in ("", "o", "odom", "odom_frame"):
        pose = (1.25, -2.5, 0.1, 0.0, 0.0, 0.6, 0.8)
        assert odometry_by_hand(7, 9, frame, "base", pose) == odometry_by_rosbags(7, 9, frame, "base", pose)


async def test_odometry_tf_sensor_and_camera_reach_the_operator_field_by_field(router: Router) -> None:
    running = await zenoh_relay(router)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        odom_key = key(*ODOM)
        pose = (1.25, -2.5, 0.125, 0.0, 0.0, 0.6, 0.8)
        tf_key = key("beta/tf", "tf2_msgs::msg::dds_::TFMessage_", "tf2_msgs/msg/TFMessage")
        static_key = key("beta/tf_static", "tf2_msgs::msg::dds_::TFMessage_", "tf2_msgs/msg/TFMessage")
        gas_key = key("alpha/gas", "std_msgs::msg::dds_::Float32_", "std_msgs/msg/Float32")

        def transform(parent: str, child: str, x: float, y: float, t: float) -> Any:
            return T["geometry_msgs/msg/TransformStamped"](
                header=header(t, parent),
                child_frame_id=child,
                transform=T["geometry_msgs/msg/Transform"](
                    translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0),
                    rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                ),
            )

        def tf(*transforms: Any) -> bytes:
            message = T["tf2_msgs/msg/TFMessage"](transforms=list(transforms))
            return bytes(STORE.serialize_cdr(message, "tf2_msgs/msg/TFMessage"))

        gas = bytes(STORE.serialize_cdr(T["std_msgs/msg/Float32"](data=412.5), "std_msgs/msg/Float32"))
        # The relay's subscriptions reach the router a moment after it started: publish until they arrive.
        for i in range(100):
            now = 1_700_000_000.5 + i
            router.put(odom_key, odometry_by_hand(int(now), 500_000_000, "odom", "base_link", pose), i)
            router.put(static_key, tf(transform("map", "odom", 1.0, 2.0, now)), i)
            router.put(tf_key, tf(transform("odom", "base_link", 0.5, 0.25, now)), i)
            router.put(gas_key, gas, i)
            # beta's pose is in the map frame once the static map -> odom has arrived too (before it, in odom).
            beta = client.pose("beta")
            if client.pose("alpha") and beta and beta["frame"] == "map" and client.latest.get("alpha/sensor/gas"):
                break
            await asyncio.sleep(0.05)
        a, b = client.pose("alpha"), client.pose("beta")
        assert a is not None and b is not None, client.messages[-3:]
        assert (a["x"], a["y"], a["z"]) == (1.25, -2.5, 0.125)
        assert (a["qx"], a["qy"], a["qz"], a["qw"]) == (0.0, 0.0, 0.6, 0.8)
        assert a["frame"] == "odom" and a["stamp"] == pytest.approx(1_700_000_000.5, abs=200)
        # beta: map -> odom (1, 2) then odom -> base_link (0.5, 0.25): the chain the bag backend composes.
        assert (b["x"], b["y"]) == (1.5, 2.25) and b["frame"] == "map"
        reading = client.latest["alpha/sensor/gas"]
        assert reading["value"] == 412.5 and reading["unit"] == "ppm"

        # A raw camera: left half red, right half blue (rgb8), asked for by a snapshot.
        pixels = np.zeros((48, 64, 3), np.uint8)
        pixels[:, :32] = (255, 0, 0)
        pixels[:, 32:] = (0, 0, 255)
        image = T["sensor_msgs/msg/Image"](
            header=header(1_700_000_100.0, "camera"), height=48, width=64, encoding="rgb8", is_bigendian=0,
            step=64 * 3, data=pixels.reshape(-1),
        )  # fmt: skip
        image_key = key("alpha/camera/image_raw", "sensor_msgs::msg::dds_::Image_", "sensor_msgs/msg/Image")
        raw = bytes(STORE.serialize_cdr(image, "sensor_msgs/msg/Image"))
        request = asyncio.ensure_future(client.request({"identifier": "alpha/snapshot", "camera": "front"}, 10))
        while not request.done():
            router.put(image_key, raw)
            await asyncio.sleep(0.05)
        reply = request.result()
        assert reply["identifier"] == "ack", reply
        _, frame_header, payload = client.frames[-1]
        assert frame_header["identifier"] == "alpha/camera/front" and frame_header["request_id"] == reply["id"]
        assert (frame_header["encoding"], frame_header["width"], frame_header["height"]) == ("jpeg", 64, 48)
        picture = cv2.imdecode(np.frombuffer(payload, np.uint8), cv2.IMREAD_COLOR)  # BGR
        assert picture is not None
        assert picture[24, 8].tolist() == pytest.approx([0, 0, 255], abs=30)  # red on the left
        assert picture[24, 56].tolist() == pytest.approx([255, 0, 0], abs=30)  # blue on the right

        # A compressed camera: the robot's JPEG (green above, white below) is passed through as it came.
        bgr = np.zeros((40, 80, 3), np.uint8)
        bgr[:20] = (0, 255, 0)
        bgr[20:] = (255, 255, 255)
        jpeg = cv2.imencode(".jpg", bgr)[1].tobytes()
        compressed = T["sensor_msgs/msg/CompressedImage"](
            header=header(1_700_000_200.0, "camera"), format="jpeg", data=np.frombuffer(jpeg, np.uint8)
        )
        jpeg_key = key(
            "alpha/camera/jpeg/compressed",
            "sensor_msgs::msg::dds_::CompressedImage_",
            "sensor_msgs/msg/CompressedImage",
        )
        raw = bytes(STORE.serialize_cdr(compressed, "sensor_msgs/msg/CompressedImage"))
        request = asyncio.ensure_future(client.request({"identifier": "alpha/snapshot", "camera": "jpeg"}, 10))
        while not request.done():
            router.put(jpeg_key, raw)
            await asyncio.sleep(0.05)
        reply = request.result()
        assert reply["identifier"] == "ack", reply
        _, frame_header, payload = client.frames[-1]
        assert frame_header["identifier"] == "alpha/camera/jpeg" and frame_header["request_id"] == reply["id"]
        assert (frame_header["width"], frame_header["height"], frame_header["stamp"]) == (80, 40, 1_700_000_200.0)
        assert payload == jpeg
    finally:
        await client.close()
        await running.runner.cleanup()


async def test_goal_and_cmd_vel_reach_the_robot_as_rmw_zenoh_sends_them(router: Router) -> None:
    goals = router.listen("0/alpha/goal_pose/geometry_msgs::msg::dds_::PoseStamped_/*")
    twists = router.listen("0/alpha/cmd_vel/*/*")
    running = await zenoh_relay(router)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        reply = await client.request({"identifier": "alpha/goal_pose", "x": 3.0, "y": -1.5, "yaw": math.pi / 2})
        assert reply["identifier"] == "ack", reply
        found = await until(goals.all, 5, "the goal")
        goal_key, payload, extra = found[-1]
        assert goal_key.endswith("/" + STORE.hash_rihs01("geometry_msgs/msg/PoseStamped"))
        goal = decode(payload, "geometry_msgs/msg/PoseStamped")
        assert goal.header.frame_id == "map" and abs(goal.header.stamp.sec - time.time()) < 5
        assert (goal.pose.position.x, goal.pose.position.y) == (3.0, -1.5)
        assert (goal.pose.orientation.z, goal.pose.orientation.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))
        # rmw_zenoh's attachment: sequence 1, a timestamp of now in ns, a 16-byte GID.
        assert extra is not None and len(extra) == 33
        sequence, stamp_ns, length = struct.unpack_from("<qqB", extra)
        assert sequence == 1 and abs(stamp_ns / 1e9 - time.time()) < 5 and length == 16

        reply = await client.request({"identifier": "alpha/cmd_vel", "linear": 2.0, "angular": 0.5})
        assert reply["identifier"] == "ack", reply
        moving = await until(
            lambda: [s for s in twists.all() if decode(s[1], "geometry_msgs/msg/Twist").linear.x],
            5,
            "a moving Twist",
        )
        twist_key, payload, _ = moving[0]
        assert "/geometry_msgs::msg::dds_::Twist_/RIHS01_" in twist_key
        twist = decode(payload, "geometry_msgs/msg/Twist")
        assert (twist.linear.x, twist.angular.z) == (0.5, 0.5)  # clamped to alpha's 0.5 m/s
        # The deadman: the operator fell silent, the robot gets a zero Twist.
        await until(lambda: decode(twists.all()[-1][1], "geometry_msgs/msg/Twist").linear.x == 0.0, 3, "a stop")
    finally:
        await client.close()
        await running.runner.cleanup()


async def test_bad_samples_are_named_and_change_nothing(
    router: Router, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    caplog.set_level(logging.WARNING)
    monkeypatch.setattr(zenoh_backend, "SILENT_AFTER", 1.0)
    running = await zenoh_relay(router)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        odom_key = key(*ODOM)
        wrong_type = "0/alpha/odom/std_msgs::msg::dds_::String_/RIHS01_00"
        pose = (4.0, 5.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        good = odometry_by_hand(1_700_000_000, 0, "odom", "base_link", pose)
        for i in range(100):
            router.put(wrong_type, good, i)  # a good body under a type the relay does not expect
            router.put(odom_key, good[:20], i)  # a corrupt body: cut short
            router.put("0/robot9/odom/nav_msgs::msg::dds_::Odometry_/RIHS01_00", good, i)  # no robot of ours
            await asyncio.sleep(0.02)
            if "String" in caplog.text and "undecodable" in caplog.text:
                break
        assert (
            wrong_type in caplog.text
            and "std_msgs/msg/String" in caplog.text
            and "nav_msgs/msg/Odometry" in caplog.text
        )
        assert "alpha: undecodable pose message (20 bytes)" in caplog.text
        assert client.pose("alpha") is None  # nothing of it reached the operator
        # The relay carries on: the next good sample is the robot's pose.
        for i in range(100):
            router.put(odom_key, good, i)
            await asyncio.sleep(0.05)
            if client.pose("alpha") is not None:
                break
        p = client.pose("alpha")
        assert p is not None and (p["x"], p["y"]) == (4.0, 5.0)
        # beta's key matches no publisher (nobody publishes beta/tf): named once the relay has waited for it.
        await until(lambda: "no pose sample on 0/beta/tf/*/*" in caplog.text, 5, "beta's silent key named")
        health = running.relay.backend.health()["zenoh"]
        assert isinstance(health, dict) and health["silent"] == {"beta": "0/beta/tf/*/*"}
    finally:
        await client.close()
        await running.runner.cleanup()


async def test_a_wrong_router_address_is_named_and_nothing_starts() -> None:
    port = free_port()  # nobody listens there
    backend = ZenohBackend(fleet(), lambda event: None, ZenohOptions(connect=(f"tcp/127.0.0.1:{port}",)))
    with pytest.raises(BackendUnavailable, match=f"tcp/127.0.0.1:{port}"):
        await backend.start()


async def test_a_router_that_goes_away_is_a_backend_failure_until_it_comes_back(router: Router) -> None:
    running = await zenoh_relay(router)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        await router.close()
        down = await client.wait_for(lambda m: m["identifier"] == "backend" and not m["ok"], timeout=5)
        assert router.endpoint in down["message"]
        await router.open()
        await client.wait_for(lambda m: m["identifier"] == "backend" and m["ok"], timeout=10)
        # The relay's subscriptions are back on the new router: poses flow again.
        pose = (7.0, 8.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        for i in range(100):
            router.put(key(*ODOM), odometry_by_hand(1_700_000_000, 0, "odom", "base_link", pose), i)
            await asyncio.sleep(0.05)
            if client.pose("alpha") is not None:
                break
        p = client.pose("alpha")
        assert p is not None and (p["x"], p["y"]) == (7.0, 8.0)
    finally:
        await client.close()
        await running.runner.cleanup()


async def test_the_demo_fleet_over_zenoh_shows_in_a_relay_map_included(tmp_path: Path) -> None:
    """tools/fake_fleet_zenoh.py (what `make run ARGS="--backend zenoh"` is shown beside) is a router with the demo's
    robots: a relay started after it gets every robot's pose, its sensors, and the map from the publisher's cache
    (a late joiner, as with a transient-local /map), and a goal moves a robot."""
    async with demo_fleet_over_zenoh() as endpoint:
        options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(endpoint,)))
        running = await start_relay(load_config(ROOT / "robots.yaml"), options=options)
        client = await TestClient.open(running.ws_url)
        try:
            await client.hello()
            await until(lambda: all(client.pose(r) for r in ("robot1", "robot2", "robot3")), 10, "the robots' poses")
            await until(lambda: client.latest.get("robot1/sensor/gas"), 10, "robot1's gas reading")
            scan = await until(lambda: client.latest.get("robot1/scan"), 10, "robot1's laser scan")
            assert scan["frame"] == "robot1/base_scan" and len(scan["ranges"]) >= 90
            assert any(r is not None and r < scan["range_max"] for r in scan["ranges"]), "the walls are seen"
            grid = await until(lambda: running.relay.router.live_map, 10, "the map (from /map, not robots.yaml)")
            assert (grid.width, grid.height) == (360, 200)
            start = client.pose("robot1")
            assert start is not None
            reply = await client.request({"identifier": "robot1/goal_pose", "x": start["x"], "y": start["y"] + 1.5})
            assert reply["identifier"] == "ack", reply
            await client.wait_pose_near("robot1", start["x"], start["y"] + 1.5, 0.3, timeout=15)
        finally:
            await client.close()
            await running.runner.cleanup()


async def test_behind_zenoh_bridge_ros2dds_keys_are_the_topics(router: Router) -> None:
    """``zenoh.keys: bridge``: zenoh-bridge-ros2dds routes a DDS topic on its name alone (no domain, no type), and
    passes no rmw_zenoh attachment."""
    goals = router.listen("alpha/goal_pose")
    config = parse_config(FLEET.replace("zenoh: {domain_id: 0}", "zenoh: {keys: bridge}"), "fleet.yaml")
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,)))
    running = await start_relay(config, options=options)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        pose = (2.0, 3.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        for _ in range(100):
            router.session.put("alpha/odom", odometry_by_hand(1_700_000_000, 0, "odom", "base_link", pose))
            await asyncio.sleep(0.05)
            if client.pose("alpha") is not None:
                break
        p = client.pose("alpha")
        assert p is not None and (p["x"], p["y"]) == (2.0, 3.0)
        reply = await client.request({"identifier": "alpha/goal_pose", "x": 1.0, "y": 2.0})
        assert reply["identifier"] == "ack", reply
        goal_key, payload, extra = (await until(goals.all, 5, "the goal"))[-1]
        assert goal_key == "alpha/goal_pose" and extra is None
        goal = decode(payload, "geometry_msgs/msg/PoseStamped")
        assert (goal.pose.position.x, goal.pose.position.y) == (1.0, 2.0)
    finally:
        await client.close()
        await running.runner.cleanup()


async def test_a_zenoh_config_file_is_passed_through_user_password_included(tmp_path: Path) -> None:
    """--zenoh-config goes to Zenoh as is: a router that asks for a user and password admits the relay with the
    right ones and refuses it, named, with wrong ones or none; a config file that cannot be read is named too."""
    (tmp_path / "users.txt").write_text("relay:s3cret\n")
    port = free_port()
    config = router_config(port)
    config.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(str(tmp_path / "users.txt")))
    config.insert_json5("transport/auth/usrpwd/user", '"router"')
    config.insert_json5("transport/auth/usrpwd/password", '"router-pw"')
    router_session = await asyncio.to_thread(zenoh.open, config)
    endpoint = f"tcp/127.0.0.1:{port}"

    def backend(config_file: str | None) -> ZenohBackend:
        return ZenohBackend(fleet(), lambda event: None, ZenohOptions(connect=(endpoint,), config=config_file))

    try:
        for name, password in (("right", "s3cret"), ("wrong", "guess")):
            usrpwd = json.dumps({"user": "relay", "password": password})
            (tmp_path / f"{name}.json5").write_text(f"{{transport: {{auth: {{usrpwd: {usrpwd}}}}}}}")
        admitted = backend(str(tmp_path / "right.json5"))
        await admitted.start()
        try:
            health = admitted.health()["zenoh"]
            assert isinstance(health, dict) and health["connected"] is True
        finally:
            await admitted.stop()
        for refused in (backend(str(tmp_path / "wrong.json5")), backend(None)):
            with pytest.raises(BackendUnavailable, match=f"cannot reach the router at {endpoint}"):
                await refused.start()
        with pytest.raises(BackendUnavailable, match=r"missing\.json5 cannot be used"):
            await backend(str(tmp_path / "missing.json5")).start()
    finally:
        await asyncio.to_thread(router_session.close)


async def test_in_peer_mode_the_relay_reaches_the_robots_too(router: Router) -> None:
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,), mode="peer"))
    running = await start_relay(fleet(), options=options)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        pose = (6.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        for i in range(100):
            router.put(key(*ODOM), odometry_by_hand(1_700_000_000, 0, "odom", "base_link", pose), i)
            await asyncio.sleep(0.05)
            if client.pose("alpha") is not None:
                break
        p = client.pose("alpha")
        assert p is not None and (p["x"], p["y"]) == (6.0, 1.0)
        health = running.relay.backend.health()["zenoh"]
        assert isinstance(health, dict) and (health["mode"], health["connected"]) == ("peer", True)
        assert running.relay.backend.failure is None
    finally:
        await client.close()
        await running.runner.cleanup()
