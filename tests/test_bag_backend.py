"""The bag backend: real recordings replayed through a real relay, checked against the bags themselves.

What clients receive over /ws is compared with what the bag contains, decoded here independently with
rosbags (in sync fixtures: decoding on the loop would trip the loop-blocking check). The shared recordings
are read from ../shared/data; the tests skip, saying so, only when that folder is absent. Replays use
--start, seeks and rates of 2-10 so that no test waits out a 28-97 s bag.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import shutil
import subprocess
import sys
import time
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from relay.backends.bag import BagContents, BagSpec, bind_bags
from relay.cli.options import BagOptions, Options
from relay.config import FleetConfig, parse_config
from relay.errors import BackendUnavailable
from tests.conftest import LOAD_SLACK, ROOT, SHARED_DATA, RunningRelay, start_relay
from tests.gltf_validate import validate_glb
from tests.wsclient import TestClient

DATA = SHARED_DATA
BAGS = DATA / "bags"
SYZYGY = BAGS / "tb3_walker_syzygy21" / "walker_data_2024_11_23_15_54_49"
KOUSTUBH = BAGS / "tb3_walker_koustubh1012" / "rosbag2_2024_11_22-20_53_49"
NAV2 = BAGS / "evo_nav2_turtlebot" / "nav2_turtlebot.mcap"
FISHEYE = DATA / "fisheye" / "surroundvision_jeyp4" / "front.jpg"

pytestmark = pytest.mark.skipif(
    not BAGS.is_dir(), reason=f"the shared recordings are not there ({BAGS}); they come with ../shared/data"
)

NAV2_FLEET = """
robots:
  - name: tb4
    pose: {source: tf, base_frame: base_link}
    limits: {linear: 0.5, angular: 1.0}
"""

SCOUT_FLEET = """
robots:
  - name: scout
    namespace: ""
    limits: {linear: 0.5, angular: 1.0}
    cameras:
      - {name: front, width: 320, height: 180}
      - {name: jpeg, compressed: true, width: 320, height: 180}
    sensors:
      - {name: gas, type: std_msgs/Float32, unit: ppm, warn_above: 150}
"""


# -- the bags as rosbags reads them, independently of the relay -------------------------------------


def header_stamp(header: Any) -> float:
    """Seconds, rounded as the wire rounds stamps (so they can be looked up)."""
    return round(float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9, 6)


def yaw_of(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def angle_between(a: float, b: float) -> float:
    return abs(math.remainder(a - b, math.tau))


@dataclass
class Recording:
    duration: float
    #: odom header stamp -> (x, y, yaw, seconds from the bag's start when it was recorded)
    odom: dict[float, tuple[float, float, float, float]]
    #: odom header stamp -> z (m)
    odom_z: dict[float, float]
    #: scan header stamp -> the ranges, None where the return is not valid
    scans: dict[float, list[float | None]]
    #: (stamp, x, y) of /amcl_pose
    amcl: list[tuple[float, float, float]]

    def position_of(self, pose: dict[str, Any]) -> float:
        return self.odom[pose["stamp"]][3]


def read_recording(path: Path) -> Recording:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    odom: dict[float, tuple[float, float, float, float]] = {}
    odom_z: dict[float, float] = {}
    scans: dict[float, list[float | None]] = {}
    amcl: list[tuple[float, float, float]] = []
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        wanted = [c for c in reader.connections if c.topic in ("/odom", "/scan", "/amcl_pose")]
        for connection, log_ns, raw in reader.messages(connections=wanted):
            message: Any = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/odom":
                pose = message.pose.pose
                odom[header_stamp(message.header)] = (
                    pose.position.x,
                    pose.position.y,
                    yaw_of(pose.orientation),
                    (log_ns - reader.start_time) * 1e-9,
                )
                odom_z[header_stamp(message.header)] = pose.position.z
            elif connection.topic == "/scan":
                scans[header_stamp(message.header)] = [
                    float(r) if math.isfinite(r) and message.range_min <= r <= message.range_max else None
                    for r in message.ranges
                ]
            else:
                p = message.pose.pose.position
                amcl.append((header_stamp(message.header), p.x, p.y))
        duration = (reader.end_time - reader.start_time) * 1e-9
    return Recording(duration, odom, odom_z, scans, amcl)


@pytest.fixture(scope="module")
def syzygy() -> Recording:
    return read_recording(SYZYGY)


@pytest.fixture(scope="module")
def koustubh() -> Recording:
    return read_recording(KOUSTUBH)


@pytest.fixture(scope="module")
def nav2() -> Recording:
    return read_recording(NAV2)


# -- helpers -----------------------------------------------------------------------------------------


@contextlib.asynccontextmanager
async def replay(
    config: FleetConfig, *bags: str | Path, rate: float = 1.0, start: float = 0.0, loop: bool = False
) -> AsyncIterator[tuple[RunningRelay, TestClient]]:
    options = Options(
        backend="bag", bag=BagOptions(bags=tuple(str(b) for b in bags), rate=rate, start=start, loop=loop)
    )
    running = await start_relay(config, options=options)
    client = await TestClient.open(running.ws_url)
    try:
        yield running, client
    finally:
        await client.close()
        await running.runner.cleanup()


def received(client: TestClient, identifier: str, start: int = 0) -> list[dict[str, Any]]:
    return [m for _, m in client.messages[start:] if m["identifier"] == identifier]


def assert_poses_match(poses: list[dict[str, Any]], recording: Recording) -> None:
    """Every pose is one the bag holds (looked up by its stamp), to 1e-3 in x, y and yaw."""
    for pose in poses:
        assert pose["stamp"] in recording.odom, f"pose stamped {pose['stamp']} is not in the bag"
        x, y, yaw, _ = recording.odom[pose["stamp"]]
        assert abs(pose["x"] - x) <= 1e-3 and abs(pose["y"] - y) <= 1e-3, (pose, x, y)
        assert angle_between(pose["yaw"], yaw) <= 1e-3, (pose, yaw)


# -- replaying the shared recordings -----------------------------------------------------------------


async def test_a_walker_bag_plays_as_robot1_with_its_recorded_odometry(
    fleet_config: FleetConfig, syzygy: Recording, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger="relay.backends.bag")
    # The demo robots.yaml, no extra flags: the bag's /odom stands in for robot1's /robot1/odom.
    async with replay(fleet_config, SYZYGY, rate=10.0) as (_, client):
        await asyncio.sleep(2.2)
        status = {name: client.latest[f"{name}/status"]["online"] for name in ("robot1", "robot2", "robot3")}
    poses = received(client, "robot1/pose")
    assert len(poses) >= 30
    assert_poses_match(poses, syzygy)
    assert {p["frame"] for p in poses} == {"odom"}
    assert math.hypot(poses[-1]["x"] - poses[0]["x"], poses[-1]["y"] - poses[0]["y"]) > 0.1, "robot1 did not move"
    # Robots bound to no bag stay offline.
    assert status == {"robot1": True, "robot2": False, "robot3": False}
    assert not received(client, "robot2/pose") and not received(client, "robot3/pose")
    # gazebo_msgs/PerformanceMetrics is unknown to the type stores: one warning, and the replay goes on.
    warnings = [r for r in caplog.records if "/performance_metrics" in r.getMessage()]
    assert len(warnings) == 1 and "gazebo_msgs/msg/PerformanceMetrics" in warnings[0].getMessage()


async def test_scans_keep_each_recorded_return_at_most_ten_a_second(
    fleet_config: FleetConfig, syzygy: Recording
) -> None:
    # At rate 5 the bag offers 25 scans a second.
    async with replay(fleet_config, SYZYGY, rate=5.0, start=5.0) as (_, client):
        await asyncio.sleep(2.5)
    scans = [(t, m) for t, m in client.messages if m["identifier"] == "robot1/scan"]
    assert len(scans) >= 10
    for _, scan in scans:
        recorded = syzygy.scans[scan["stamp"]]
        assert len(scan["ranges"]) == len(recorded) <= 360
        for got, want in zip(scan["ranges"], recorded, strict=True):
            assert (got is None and want is None) or (
                got is not None and want is not None and abs(got - want) <= 0.006
            ), (got, want)
    times = [t for t, _ in scans]
    # 10 a second, 11 in a second with the cap's credit; by arrival, a client that waited for a CPU on a loaded
    # machine reads a few late ones together, which the average over the whole replay does not see
    assert max(sum(1 for u in times if t <= u < t + 1.0) for t in times) <= 11 + 3
    assert (len(times) - 1) / (times[-1] - times[0]) <= 10.5


async def test_the_nav2_mcap_gives_the_map_frame_pose_amcl_estimated(nav2: Recording) -> None:
    config = parse_config(NAV2_FLEET, "nav2.yaml")
    # AMCL's first estimate is at 4.6 s; 3.5 s at rate 10 covers 35 s of driving.
    async with replay(config, NAV2, rate=10.0, start=4.0) as (_, client):
        await asyncio.sleep(3.5)
    poses = received(client, "tb4/pose")
    assert poses and {p["frame"] for p in poses} == {"map"}
    compared = 0
    for pose in poses:
        stamp, x, y = min(nav2.amcl, key=lambda a: abs(a[0] - pose["stamp"]))
        if abs(stamp - pose["stamp"]) <= 0.05:
            compared += 1
            assert math.hypot(pose["x"] - x, pose["y"] - y) <= 0.3, (pose, stamp, x, y)
    assert compared >= 10
    xs, ys = [p["x"] for p in poses], [p["y"] for p in poses]
    assert max(xs) - min(xs) + max(ys) - min(ys) > 1.0, "tb4 did not drive"


async def test_a_tf_pose_reaches_the_configured_base_frame_through_tf_static(syzygy: Recording) -> None:
    # The walker publishes odom->base_footprint on /tf and base_footprint->base_link on /tf_static; it runs
    # no localisation (no map->odom), so the pose is in the odom frame, where /odom has it too.
    config = parse_config(
        "robots:\n  - name: robot1\n    pose: {source: tf, base_frame: base_link}\n"
        "    limits: {linear: 0.5, angular: 1.0}\n",
        "tf.yaml",
    )
    async with replay(config, SYZYGY, rate=10.0, start=8.0) as (_, client):
        await asyncio.sleep(1.2)
    poses = received(client, "robot1/pose")
    assert len(poses) >= 10 and {p["frame"] for p in poses} == {"odom"}
    assert_poses_match(poses, syzygy)
    # base_link is 1 cm above base_footprint (/tf_static): the pose is base_link's, not the footprint's.
    assert all(abs(p["z"] - (syzygy.odom_z[p["stamp"]] + 0.01)) <= 1e-3 for p in poses)


async def test_two_bags_play_as_two_robots_at_once(
    fleet_config: FleetConfig, syzygy: Recording, koustubh: Recording
) -> None:
    async with replay(fleet_config, f"robot1={SYZYGY}", f"robot2={KOUSTUBH}", rate=5.0, start=3.0) as (_, client):
        await asyncio.sleep(2.5)
    for robot, recording in (("robot1", syzygy), ("robot2", koustubh)):
        poses = received(client, f"{robot}/pose")
        assert len(poses) >= 20, robot
        # Each robot's poses are its own bag's, stamp for stamp.
        assert_poses_match(poses, recording)
        assert math.hypot(poses[-1]["x"] - poses[0]["x"], poses[-1]["y"] - poses[0]["y"]) > 0.1, f"{robot} is still"
    assert not received(client, "robot3/pose")


async def test_rate_pause_and_seek_control_the_replay(fleet_config: FleetConfig, syzygy: Recording) -> None:
    async with replay(fleet_config, SYZYGY, rate=1.0, start=2.0) as (running, client):
        hello = await client.hello()
        playback = hello["playback"]
        assert playback["duration"] == pytest.approx(syzygy.duration, abs=0.01)
        assert (playback["rate"], playback["paused"], playback["loop"]) == (1.0, False, False)

        # Rate 2: the recording advances twice as fast as the wall clock.
        assert (await client.request({"identifier": "playback/rate", "rate": 2.0}))["identifier"] == "ack"
        await asyncio.sleep(0.3)
        mark = len(client.messages)
        await asyncio.sleep(1.5)
        window = [(t, m) for t, m in client.messages[mark:] if m["identifier"] == "robot1/pose"]
        (t0, first), (t1, last) = window[0], window[-1]
        speed = (syzygy.position_of(last) - syzygy.position_of(first)) / (t1 - t0)
        assert 1.5 <= speed <= 2.6, speed

        # Pause: the poses stop advancing, yet the robot stays online (offline_after is 2 s).
        assert (await client.request({"identifier": "playback/pause"}))["identifier"] == "ack"
        await client.wait_for(lambda m: m["identifier"] == "playback" and m["paused"], start=mark)
        await asyncio.sleep(0.3)
        mark = len(client.messages)
        await asyncio.sleep(2.3)
        assert len({p["stamp"] for p in received(client, "robot1/pose", mark)}) <= 1
        assert len({p["position"] for p in received(client, "playback", mark)}) <= 1
        assert client.latest["robot1/status"]["online"] is True
        health = running.relay.backend.health()
        assert health["playback"]["paused"] is True  # type: ignore[index]
        # /healthz answers anyone: bag names, never the paths where the relay keeps them.
        assert all("/" not in bag["name"] and "path" not in bag for bag in health["bags"])  # type: ignore[attr-defined]

        # Seek while paused shows the recording at t at once.
        mark = len(client.messages)
        assert (await client.request({"identifier": "playback/seek", "t": 20.0}))["identifier"] == "ack"
        at_t = await client.wait_for(
            lambda m: m["identifier"] == "robot1/pose" and syzygy.position_of(m) > 15.0, start=mark
        )
        assert 19.5 <= syzygy.position_of(at_t) <= 20.05
        report = client.latest["playback"]
        assert (report["position"], report["paused"]) == (20.0, True)

        # Resume: the replay goes on from t, never from before it.
        after_seek = client.messages.index(next(x for x in client.messages if x[1] is at_t))
        assert (await client.request({"identifier": "playback/resume"}))["identifier"] == "ack"
        await client.wait_for(
            lambda m: m["identifier"] == "robot1/pose" and syzygy.position_of(m) > 21.0,
            timeout=3.0 + LOAD_SLACK,
            start=mark,
        )
        later = received(client, "robot1/pose", after_seek)
        assert all(syzygy.position_of(p) >= 19.5 for p in later)
        assert 20.0 < running.relay.backend.health()["playback"]["position"] < 25.0  # type: ignore[index]


async def test_the_replay_stays_paused_at_the_end_or_loops(fleet_config: FleetConfig, syzygy: Recording) -> None:
    last_stamp = max(syzygy.odom)
    async with replay(fleet_config, SYZYGY, rate=4.0, start=26.5) as (_, client):
        end = await client.wait_for(lambda m: m["identifier"] == "playback" and m["paused"], timeout=3.0 + LOAD_SLACK)
        assert end["position"] == pytest.approx(syzygy.duration, abs=0.01)
        await asyncio.sleep(0.2)
        assert client.latest["robot1/pose"]["stamp"] == last_stamp
    async with replay(fleet_config, SYZYGY, rate=4.0, start=26.5, loop=True) as (_, client):
        again = await client.wait_for(
            lambda m: m["identifier"] == "robot1/pose" and syzygy.position_of(m) < 2.0, timeout=3.0 + LOAD_SLACK
        )
        assert_poses_match([again], syzygy)
        looping = await client.wait_for(
            lambda m: m["identifier"] == "playback" and m["loop"] is True and m["paused"] is False, 3.0 + LOAD_SLACK
        )
        assert looping["position"] < syzygy.duration


async def test_commands_to_a_recording_are_refused_and_the_replay_goes_on(fleet_config: FleetConfig) -> None:
    async with replay(fleet_config, SYZYGY, rate=2.0, start=10.0) as (_, client):
        for robot in ("robot1", "robot2"):  # robot1 is the recording; robot2 is in none
            for command in (
                {"identifier": f"{robot}/cmd_vel", "linear": 0.2, "angular": 0.0},
                {"identifier": f"{robot}/goal_pose", "x": 1.0, "y": 0.5},
                {"identifier": f"{robot}/cancel"},
            ):
                reply = await client.request(command)
                assert reply["identifier"] == "error" and reply["code"] == "recording", reply
                assert robot in reply["message"]
        refused = await client.request({"identifier": "robot1/goal_pose", "x": 1.0, "y": 0.5})
        assert "recording" in refused["message"] and SYZYGY.name in refused["message"]
        # The stop paths reach the backend and are harmless.
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        mark = len(client.messages)
        await client.send({"identifier": "ping", "t": 1.0})
        await client.wait_for(lambda m: m["identifier"] == "pong", start=mark)
        await client.wait_for(lambda m: m["identifier"] == "robot1/pose", start=mark)


# -- bad bags and bad bindings -----------------------------------------------------------------------


def broken_bags(directory: Path) -> list[Path]:
    """A truncated sqlite3 bag, a truncated MCAP and an MCAP with garbage in place of its data."""
    truncated = directory / "truncated_db3"
    shutil.copytree(SYZYGY, truncated)
    database = next(truncated.glob("*.db3"))
    database.chmod(0o644)
    with database.open("r+b") as file:
        file.truncate(database.stat().st_size // 4)
    half = directory / "half.mcap"
    data = NAV2.read_bytes()
    half.write_bytes(data[: len(data) // 2])
    garbage = directory / "garbage.mcap"
    garbage.write_bytes(bytes(reversed(data)))
    return [truncated, half, garbage]


async def test_a_truncated_or_corrupt_bag_is_refused_naming_the_file(fleet_config: FleetConfig, tmp_path: Path) -> None:
    for bad in broken_bags(tmp_path):
        with pytest.raises(BackendUnavailable) as refused:
            await start_relay(fleet_config, options=Options(backend="bag", bag=BagOptions(bags=(str(bad),))))
        assert str(bad) in str(refused.value) and "cannot read this bag" in str(refused.value)


def test_the_relay_exits_with_status_2_and_one_line_for_a_bad_bag(tmp_path: Path) -> None:
    bad = broken_bags(tmp_path)[0]
    result = subprocess.run(
        [sys.executable, "-m", "relay", "--backend", "bag", "--bag", str(bad), "--port", "0", "--no-accounts"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert str(bad) in lines[0] and "Traceback" not in result.stderr


async def test_unknown_robots_and_missing_pose_topics_are_clear_errors(fleet_config: FleetConfig) -> None:
    with pytest.raises(BackendUnavailable, match=r"unknown robot 'robot9'.*robot1, robot2, robot3"):
        await start_relay(fleet_config, options=Options(backend="bag", bag=BagOptions(bags=(f"robot9={SYZYGY}",))))
    # The pose topic is not in the bag, but TF is: the error says how to use it.
    config = parse_config(
        "robots:\n  - name: robot1\n    pose: {source: odom, topic: odometry/filtered}\n"
        "    limits: {linear: 0.5, angular: 1.0}\n",
        "fleet.yaml",
    )
    with pytest.raises(BackendUnavailable) as refused:
        await start_relay(config, options=Options(backend="bag", bag=BagOptions(bags=(str(SYZYGY),))))
    message = str(refused.value)
    assert str(SYZYGY) in message and "/robot1/odometry/filtered" in message
    assert "/tf" in message and "source: tf" in message and "fleet.yaml" in message


def test_bags_bind_to_robots_by_name_by_namespace_or_in_order(fleet_config: FleetConfig) -> None:
    def contents(*topics: str) -> BagContents:
        types = {"odom": "nav_msgs/msg/Odometry", "scan": "sensor_msgs/msg/LaserScan"}
        return BagContents(0, 10**9, {t: types[t.rsplit("/", 1)[1]] for t in topics})

    single, fleet = contents("/odom", "/scan"), contents("/robot2/odom", "/robot3/odom", "/robot3/scan")

    def bound(*specs: tuple[str | None, BagContents]) -> list[dict[str, tuple[str, str | None]]]:
        bags = [BagSpec(f"bag{i}", Path(f"bag{i}"), robot) for i, (robot, _) in enumerate(specs)]
        plans = bind_bags(fleet_config, bags, [c for _, c in specs])
        return [{t.robot.name: (t.pose, t.scan) for t in plan.robots} for plan in plans]

    # An un-namespaced bag plays as the first robot not yet bound, its topics standing in for the robot's.
    assert bound((None, single), (None, single)) == [
        {"robot1": ("/odom", "/scan")},
        {"robot2": ("/odom", "/scan")},
    ]
    assert bound((None, single), ("robot1", single)) == [
        {"robot2": ("/odom", "/scan")},
        {"robot1": ("/odom", "/scan")},
    ]
    # A recording of the fleet plays as the robots whose own topics it holds.
    assert bound(
        (None, fleet),
    ) == [{"robot2": ("/robot2/odom", None), "robot3": ("/robot3/odom", "/robot3/scan")}]
    with pytest.raises(BackendUnavailable, match="no robot left"):
        bound((None, single), (None, single), (None, single), (None, single))
    with pytest.raises(BackendUnavailable, match=r"bag0: .*/scan is nav_msgs/msg/Odometry.*LaserScan"):
        bound((None, BagContents(0, 1, {"/odom": "nav_msgs/msg/Odometry", "/scan": "nav_msgs/msg/Odometry"})))


# -- cameras, sensors and a scan denser than the wire allows (a bag written here from real data) -------


@dataclass
class ScoutRecording:
    path: Path
    photo: np.ndarray[Any, np.dtype[np.uint8]]  # BGR, as recorded
    gas: dict[float, float]  # stamp -> value
    scans: dict[float, list[float | None]]  # stamp -> the nearest valid return of each pair of beams


@pytest.fixture(scope="module")
def scout(tmp_path_factory: pytest.TempPathFactory) -> ScoutRecording:
    """An MCAP written with rosbags: the walker's first 6 s of /odom, its /scan with each beam split in two
    (720 beams, one of each pair nearer or farther), a real fisheye photo as raw and JPEG images at 2 Hz, and
    a gas reading rising past its threshold."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types: Any = store.types
    original = cv2.imread(str(FISHEYE))
    assert original is not None, FISHEYE
    photo: np.ndarray[Any, np.dtype[np.uint8]] = np.asarray(cv2.resize(original, (320, 180)), dtype=np.uint8)
    rgb = cv2.cvtColor(photo, cv2.COLOR_BGR2RGB)
    jpeg = cv2.imencode(".jpg", photo, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
    out = tmp_path_factory.mktemp("bags") / "scout"
    records: list[tuple[int, str, bytes]] = []
    gas: dict[float, float] = {}
    scans: dict[float, list[float | None]] = {}
    with AnyReader([SYZYGY], default_typestore=store) as reader:
        wanted = [c for c in reader.connections if c.topic in ("/odom", "/scan")]
        start = reader.start_time
        for connection, log_ns, raw in reader.messages(connections=wanted, stop=start + 6 * 10**9):
            if connection.topic == "/odom":
                records.append((log_ns, "/odom", bytes(raw)))
                continue
            scan: Any = reader.deserialize(raw, connection.msgtype)
            original = np.asarray(scan.ranges, dtype=np.float32)
            nearer = np.arange(len(original)) % 3 == 0
            other = np.where(nearer, original - np.float32(0.1), original + np.float32(0.05)).astype(np.float32)
            dense = np.stack([original, other], axis=1).reshape(-1)
            denser = dataclasses.replace(scan, ranges=dense, angle_increment=scan.angle_increment / 2)
            records.append((log_ns, "/scan", bytes(store.serialize_cdr(denser, connection.msgtype))))

            def valid(r: float, s: Any = scan) -> bool:
                return math.isfinite(r) and s.range_min <= r <= s.range_max

            scans[header_stamp(scan.header)] = [
                min((float(r) for r in pair if valid(float(r))), default=None) for pair in dense.reshape(-1, 2)
            ]
    for k in range(12):
        log_ns = start + k * 500_000_000
        stamp = types["builtin_interfaces/msg/Time"](sec=1_700_000_000 + k // 2, nanosec=(k % 2) * 500_000_000)
        header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="camera")
        image = types["sensor_msgs/msg/Image"](
            header=header, height=180, width=320, encoding="rgb8", is_bigendian=0, step=960, data=rgb.reshape(-1)
        )
        compressed = types["sensor_msgs/msg/CompressedImage"](
            header=header, format="jpeg", data=np.frombuffer(jpeg, dtype=np.uint8)
        )
        value = 100.0 + 10.0 * k
        gas[round(log_ns * 1e-9, 6)] = value
        for topic, message in (
            ("/camera/image_raw", image),
            ("/camera/image_raw/compressed", compressed),
            ("/gas", types["std_msgs/msg/Float32"](data=value)),
        ):
            records.append((log_ns, topic, bytes(store.serialize_cdr(message, message.__msgtype__))))
    topic_types = {
        "/odom": "nav_msgs/msg/Odometry",
        "/scan": "sensor_msgs/msg/LaserScan",
        "/camera/image_raw": "sensor_msgs/msg/Image",
        "/camera/image_raw/compressed": "sensor_msgs/msg/CompressedImage",
        "/gas": "std_msgs/msg/Float32",
    }
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {t: writer.add_connection(t, m, typestore=store) for t, m in topic_types.items()}
        for log_ns, topic, data in sorted(records, key=lambda r: r[0]):
            writer.write(connections[topic], log_ns, data)
    return ScoutRecording(out, photo, gas, scans)


async def wait_frame(
    client: TestClient, identifier: str, request_id: str | None, timeout: float = 5.0
) -> tuple[dict[str, Any], bytes]:
    """The first binary frame of camera ``identifier`` answering ``request_id`` (None: streamed)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for _, header, payload in client.frames:
            if header["identifier"] == identifier and header["request_id"] == request_id:
                return header, payload
        await asyncio.sleep(0.02)
    raise TimeoutError(f"no frame of {identifier} for request {request_id!r}")


async def test_cameras_sensors_and_dense_scans_replay_from_a_bag(scout: ScoutRecording) -> None:
    config = parse_config(SCOUT_FLEET, "scout.yaml")
    async with replay(config, scout.path, rate=2.0) as (_, client):
        await client.wait_for(lambda m: m["identifier"] == "scout/sensor")
        # A snapshot of either camera is the recorded photo, as a JPEG of the recorded size.
        for camera in ("front", "jpeg"):
            reply = await client.request({"identifier": "scout/snapshot", "camera": camera})
            assert reply["identifier"] == "ack", reply
            header, payload = await wait_frame(client, f"scout/camera/{camera}", reply["id"])
            image = cv2.imdecode(np.frombuffer(payload, dtype=np.uint8), cv2.IMREAD_COLOR)
            assert (header["width"], header["height"], header["encoding"]) == (320, 180, "jpeg")
            assert image is not None and image.shape == (180, 320, 3)
            assert float(np.mean(cv2.absdiff(image, scout.photo))) < 8.0
        # A stream delivers frames without a request id.
        assert (await client.request({"identifier": "scout/stream", "camera": "front", "fps": 5}))[
            "identifier"
        ] == "ack"
        await wait_frame(client, "scout/camera/front", None)
        await asyncio.sleep(1.5)
    readings = received(client, "scout/sensor")
    assert len(readings) >= 4
    for reading in readings:
        assert reading["value"] == scout.gas[reading["stamp"]]
        assert reading["warning"] is (reading["value"] > 150) and reading["unit"] == "ppm"
    scans = received(client, "scout/scan")
    assert scans
    for scan in scans:
        expected = scout.scans[scan["stamp"]]
        # 720 beams become 360, each the nearest valid return of its pair: no obstacle disappears.
        assert len(scan["ranges"]) == len(expected) == 360
        for got, want in zip(scan["ranges"], expected, strict=True):
            assert (got is None and want is None) or (
                got is not None and want is not None and abs(got - want) <= 0.006
            ), (got, want)


async def test_a_recorded_raw_camera_streams_as_h264_with_no_jpeg_encoded(scout: ScoutRecording) -> None:
    """Only H.264 viewers of a recorded raw camera: the bag backend skips the JPEG encode (set_jpeg), every packet
    decodes with FFmpeg's decoder into the recorded photo, and a snapshot meanwhile is still a JPEG."""
    import av

    config = parse_config(SCOUT_FLEET, "scout.yaml")
    # Looping: an encoder that waits for a CPU on a loaded machine drops frames, and 3 s of replay may not hold four.
    async with replay(config, scout.path, rate=2.0, loop=True) as (running, client):
        await client.hello()
        reply = await client.request({"identifier": "scout/stream", "camera": "front", "fps": 5, "codec": "h264"})
        assert reply["identifier"] == "ack", reply
        deadline = time.monotonic() + 20
        video: list[tuple[dict[str, Any], bytes]] = []
        while time.monotonic() < deadline and len(video) < 4:
            await asyncio.sleep(0.1)
            video = [(h, p) for _, h, p in client.frames if h["identifier"] == "scout/camera/front"]
        assert len(video) >= 4 and all(h["encoding"] == "h264" for h, _ in video), [h for h, _ in video]
        decoder: Any = av.CodecContext.create("h264", "r")
        for _, payload in video:
            (picture,) = decoder.decode(av.Packet(payload))
            image = picture.to_ndarray(format="bgr24")
            assert image.shape == (180, 320, 3)
            assert float(np.mean(cv2.absdiff(image, scout.photo))) < 12.0, "the recorded photo"
        frames = running.relay.backend._cameras.encoder("scout", "front")  # type: ignore[attr-defined]
        assert frames is not None
        assert frames.last is None, "no JPEG made for a video-only stream (a frame with one would be kept as last)"
        reply = await client.request({"identifier": "scout/snapshot", "camera": "front"}, timeout=15)
        assert reply["identifier"] == "ack", reply
        header, payload = await wait_frame(client, "scout/camera/front", reply["id"])
        assert header["encoding"] == "jpeg"
        assert cv2.imdecode(np.frombuffer(payload, np.uint8), cv2.IMREAD_COLOR) is not None


async def test_robot_description_in_a_bag_becomes_the_robot_model() -> None:
    """robots.yaml asks for the model from robot_description: the URDF recorded in the walker bag (TurtleBot3
    Waffle Pi) becomes a glTF served by the relay, with the meshes of the shared turtlebot3_description."""
    config = parse_config(
        "robots:\n"
        "  - name: tb3\n"
        f"    model: {{robot_description: robot_description, packages: ['{DATA / 'robot'}']}}\n"
        "    limits: {linear: 0.26, angular: 1.82}\n",
        "fleet.yaml",
    )
    running = await start_relay(config, options=Options(backend="bag", bag=BagOptions(bags=(str(SYZYGY),), start=20)))
    try:
        # Built off the loop when the bag opens; then every client finds it in hello (and a connected one
        # gets tb3/model).
        deadline = time.monotonic() + 30
        while "tb3" not in running.relay.model_urls and time.monotonic() < deadline:  # noqa: ASYNC110
            await asyncio.sleep(0.1)
        client = await TestClient.open(running.ws_url)
        model = {"url": (await client.hello())["robots"][0]["model"]}
        assert model["url"].startswith("/scenes/generated/robot-tb3-")
        import aiohttp

        async with aiohttp.ClientSession() as http, http.get(running.url + model["url"]) as response:
            glb = await response.read()
        report = await asyncio.to_thread(validate_glb, glb)
        assert report["issues"]["numErrors"] == 0
        assert b"base_link" in glb and b"wheel_left_link" in glb  # the robot's own links, not the fallback
        await client.close()
    finally:
        await running.runner.cleanup()
