"""The robots' own clouds over real DDS (issue #33): a robot process (tests/ros_peer.py, rclpy, the Kilted wheels)
publishes the shared Velodyne scan as PointCloud2 and a Kinect frame as a 16UC1 depth Image with its CameraInfo,
and odometry; the relay (ros backend, port 0) fuses them into the map, which holds their voxels to 99 %. Each test
has its own ROS_DOMAIN_ID, discovery on this machine only."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

import pytest

from relay.cli.options import Options
from relay.config import parse_config
from tests.conftest import start_relay
from tests.helpers.cloud_live import BETA, FLEET, STARTING, fused, messages, reference, similar
from tests.helpers.cloud_messages import STORE
from tests.helpers.ros import start_peer

pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'` installs the ROS 2 wheels")

pytestmark = pytest.mark.ros

# Imported here rather than by the relay's start-up thread: importing holds the GIL for long stretches.
import geometry_msgs.msg  # noqa: E402, F401
import nav_msgs.msg  # noqa: E402, F401
import sensor_msgs.msg  # noqa: E402
import std_msgs.msg  # noqa: E402, F401


def serialized(folder: Path) -> list[dict[str, str]]:
    """Each cloud message as a CDR file for the peer, which restamps it as it sends it (blocking)."""
    out = []
    for topic, (type_name, message) in messages(time.time()).items():
        path = folder / (topic.strip("/").replace("/", "_") + ".cdr")
        path.write_bytes(bytes(STORE.serialize_cdr(message, type_name)))
        out.append({"topic": topic, "type": type_name, "file": str(path)})
    return out


async def test_a_robots_pointcloud2_and_depth_image_over_dds_grow_the_map(ros_domain: int, tmp_path: Path) -> None:
    raw = await asyncio.to_thread(serialized, tmp_path)
    x, y, yaw = BETA
    poses = [{"kind": "odom", "topic": "/alpha/odom", "x": 0.0, "y": 0.0, "yaw": 0.0},
             {"kind": "odom", "topic": "/beta/odom", "x": x, "y": y, "yaw": yaw}]  # fmt: skip
    peer = await start_peer({"poses": poses, "raw": raw, "rate": 5.0}, tmp_path)
    running = await start_relay(
        parse_config(FLEET, "fleet.yaml"), options=Options(backend="ros", database=str(tmp_path / "db.sqlite"))
    )
    try:
        fusion = await fused(running, each=2)
        occupied = await fusion.run(lambda voxels: voxels.occupied())
        health = running.relay.backend.health()
    finally:
        await running.runner.cleanup()
        await peer.stop()
    clouds = health["clouds"]
    assert isinstance(clouds, dict)
    for entry in clouds.values():  # only what a cloud may meet as the robots start
        assert entry["last_error"] is None or entry["last_error"].startswith(STARTING), entry
    recall, precision = similar(occupied, await asyncio.to_thread(reference))
    assert recall >= 0.99 and precision >= 0.99, (recall, precision)


def test_a_cloud_without_a_mount_needs_tf2_msgs_and_the_error_names_it() -> None:
    from relay.backends.ros import check_messages
    from relay.errors import BackendUnavailable

    try:
        import tf2_msgs.msg  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("this ROS install has tf2_msgs: a cloud placed by /tf_static is fine")
    fleet = FLEET.replace("mount: {}", "rate: 2")
    with pytest.raises(BackendUnavailable) as caught:
        check_messages(parse_config(fleet, "fleet.yaml"))
    message = str(caught.value)
    assert (
        "alpha: a cloud without a mount (placed through /alpha/tf_static) needs the message package tf2_msgs" in message
    )
    assert "give clouds a mount in robots.yaml" in message
    assert (
        check_messages(parse_config(FLEET, "fleet.yaml"))["sensor_msgs.msg.PointCloud2"] is sensor_msgs.msg.PointCloud2
    )
