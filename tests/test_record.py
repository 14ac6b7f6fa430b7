"""``xr-relay record`` against a live ROS 2 graph, and its recording replayed by the bag backend.

Publishers run in their own process (tests/ros_peer.py) on this test's own ROS_DOMAIN_ID with
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the recorder runs as users run it (tools/record.py, the same
``main`` as ``xr-relay record``). The ROS test skips, saying so, only when rclpy is not importable.
"""

from __future__ import annotations

import asyncio
import json
import math
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from relay.cli.options import BagOptions, Options
from relay.config import load_config
from tests.conftest import ROOT, start_relay
from tests.wsclient import TestClient

FLEET = """
robots:
  - name: robot1
    pose: odom
    limits: {linear: 0.5, angular: 1.0}
    scan: null
    sensors:
      - {name: gas, type: std_msgs/Float32, unit: ppm, warn_above: 400}
      - {name: temperature, type: sensor_msgs/Temperature, warn_above: 45}
"""

#: What the peer publishes at 20 Hz: robot1's odometry and two sensors.
PEER = {
    "poses": [{"kind": "odom", "topic": "/robot1/odom", "x": 1.25, "y": -2.5, "yaw": 0.75, "frame": "odom"}],
    "sensors": [
        {"topic": "/robot1/gas", "type": "Float32", "value": 432.5},
        {"topic": "/robot1/temperature", "type": "Temperature", "value": 21.25},
    ],
    "rate": 20.0,
}


def read_back(path: Path) -> dict[str, Any]:
    """The recording as rosbags reads it without any default type store: the bag must define its types."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        odom: list[tuple[float, float, float, float]] = []
        values: dict[str, set[float]] = {"/robot1/gas": set(), "/robot1/temperature": set()}
        for connection, _, raw in reader.messages():
            message: Any = reader.deserialize(raw, connection.msgtype)
            if connection.topic == "/robot1/odom":
                p, q = message.pose.pose.position, message.pose.pose.orientation
                stamp = round(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9, 6)
                odom.append((stamp, p.x, p.y, math.atan2(2 * q.w * q.z, 1 - 2 * q.z * q.z)))
            elif connection.topic == "/robot1/gas":
                values[connection.topic].add(message.data)
            elif connection.topic == "/robot1/temperature":
                values[connection.topic].add(message.temperature)
    return {"types": types, "odom": odom, "values": values}


@pytest.fixture
def rclpy_importable() -> None:
    """A sync fixture: importing rclpy takes ~0.5 s, which must not happen on the test's event loop."""
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'` installs the ROS 2 wheels")


@pytest.mark.usefixtures("rclpy_importable")
async def test_a_recording_of_a_live_graph_replays_with_the_values_published(ros_domain: int, tmp_path: Path) -> None:
    config_path = tmp_path / "fleet.yaml"
    config_path.write_text(FLEET)
    spec = tmp_path / "peer.json"
    spec.write_text(json.dumps(PEER))
    peer = await asyncio.create_subprocess_exec(
        sys.executable, str(ROOT / "tests" / "ros_peer.py"), str(spec), cwd=ROOT, stdout=asyncio.subprocess.PIPE
    )
    timed, stopped = tmp_path / "timed", tmp_path / "stopped"
    recorders: list[asyncio.subprocess.Process] = []
    try:
        assert peer.stdout is not None
        assert json.loads(await asyncio.wait_for(peer.stdout.readline(), 30.0)) == {"ready": True}

        async def record(out: Path, *extra: str) -> asyncio.subprocess.Process:
            process = await asyncio.create_subprocess_exec(
                sys.executable,
                str(ROOT / "tools" / "record.py"),
                "--out",
                str(out),
                "--config",
                str(config_path),
                *extra,
                cwd=ROOT,
                stdout=asyncio.subprocess.PIPE,
                stderr=asyncio.subprocess.PIPE,
            )
            recorders.append(process)
            return process

        # One recorder stops after --duration, the other on Ctrl-C, both closing their bag. DDS discovery
        # can take ~3 s on a busy machine: Ctrl-C comes 1 s after the recorder said it gets every topic.
        with_duration = await record(timed, "--duration", "5")
        interrupted = await record(stopped)
        assert interrupted.stderr is not None
        started: list[str] = []
        while len(started) < 3:
            line = (await asyncio.wait_for(interrupted.stderr.readline(), 20.0)).decode()
            assert line, "the recorder ended before recording every topic"
            if "INFO relay.cli.record: recording /robot1/" in line:
                started.append(line)
        await asyncio.sleep(1.0)
        interrupted.send_signal(signal.SIGINT)
        out, err = await asyncio.wait_for(with_duration.communicate(), 30.0)
        assert with_duration.returncode == 0, err.decode()
        assert b"recorded" in out, err.decode()
        logs = {"timed": err.decode()}
        _, err = await asyncio.wait_for(interrupted.communicate(), 30.0)
        assert interrupted.returncode == 0, err.decode()
        logs["stopped"] = "".join(started) + err.decode()
    finally:
        # Whatever failed, no process of this test outlives it.
        for process in (*recorders, peer):
            if process.returncode is None:
                process.terminate()
            await process.wait()

    timed_bag, stopped_bag = await asyncio.gather(
        asyncio.to_thread(read_back, timed), asyncio.to_thread(read_back, stopped)
    )
    for name, bag in (("timed", timed_bag), ("stopped", stopped_bag)):
        # The published topics, under their ROS types; what nobody published is not in the bag.
        assert bag["types"] == {
            "/robot1/odom": "nav_msgs/msg/Odometry",
            "/robot1/gas": "std_msgs/msg/Float32",
            "/robot1/temperature": "sensor_msgs/msg/Temperature",
        }, logs[name]
        assert len(bag["odom"]) >= 5, logs[name]
        assert {(x, y) for _, x, y, _ in bag["odom"]} == {(1.25, -2.5)}
        assert bag["values"] == {"/robot1/gas": {432.5}, "/robot1/temperature": {21.25}}

    # The recording replays through the bag backend with the values that were published.
    config = load_config(config_path)
    running = await start_relay(config, options=Options(backend="bag", bag=BagOptions(bags=(str(timed),), rate=4.0)))
    client = await TestClient.open(running.ws_url)
    try:
        await client.wait_for(lambda m: m["identifier"] == "robot1/sensor" and m["name"] == "temperature")
        await client.wait_for(lambda m: m["identifier"] == "robot1/pose")
        await asyncio.sleep(0.3)
    finally:
        await client.close()
        await running.runner.cleanup()
    recorded_stamps = {stamp for stamp, *_ in timed_bag["odom"]}
    poses = [m for _, m in client.messages if m["identifier"] == "robot1/pose"]
    for pose in poses:
        assert pose["stamp"] in recorded_stamps
        assert (pose["x"], pose["y"], pose["frame"]) == (1.25, -2.5, "odom")
        assert pose["yaw"] == pytest.approx(0.75, abs=1e-6)
    sensors = {m["name"]: m for _, m in client.messages if m["identifier"] == "robot1/sensor"}
    assert (sensors["gas"]["value"], sensors["gas"]["warning"]) == (432.5, True)
    assert (sensors["temperature"]["value"], sensors["temperature"]["warning"]) == (21.25, False)


def test_without_rclpy_the_recorder_exits_2_saying_how_to_get_it(tmp_path: Path) -> None:
    # A None entry in sys.modules makes `import rclpy` fail, as on a machine without ROS.
    script = (
        "import sys; sys.modules['rclpy'] = None; from relay.cli.record import main; "
        f"sys.exit(main(['--out', {str(tmp_path / 'bag')!r}, '--config', {str(ROOT / 'robots.yaml')!r}]))"
    )
    result = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=60)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert "rclpy" in lines[0] and "pip install" in lines[0] and "Traceback" not in result.stderr
    assert not (tmp_path / "bag").exists()
