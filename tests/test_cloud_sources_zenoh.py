"""The robots' own clouds over Zenoh (issue #33): robots under rmw_zenoh, as tests/zenoh_robots.py plays them through
a real router on loopback, send the shared Velodyne scan as PointCloud2 and a Kinect frame as a 16UC1 depth Image
with its CameraInfo, and odometry (CDR by rosbags, rmw_zenoh's keys and attachment); the relay (zenoh backend,
port 0) fuses them into the map, which holds their voxels to 99 %."""

from __future__ import annotations

import asyncio
import time
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

import numpy as np  # noqa: E402

from relay.cli.options import Options, ZenohOptions  # noqa: E402
from relay.config import parse_config  # noqa: E402
from tests.conftest import start_relay  # noqa: E402
from tests.helpers.cloud_live import (  # noqa: E402
    FLEET,
    STARTING,
    beta_pose,
    fused,
    messages,
    reference,
    similar,
)
from tests.helpers.cloud_messages import STORE, odometry  # noqa: E402
from tests.helpers.zenoh import Router  # noqa: E402
from tests.zenoh_robots import key  # noqa: E402

ODOMETRY = "nav_msgs/msg/Odometry"


def dds(type_name: str) -> str:
    """rmw_zenoh's DDS spelling of a type: ``sensor_msgs/msg/Image`` -> ``sensor_msgs::msg::dds_::Image_``."""
    package, _, name = type_name.rpartition("/")
    return f"{package.replace('/', '::')}::dds_::{name}_"


def samples(stamp: float) -> list[tuple[str, bytes]]:
    """(key, CDR) of every robot's clouds and odometry stamped ``stamp`` (blocking: reads and serializes)."""
    out = [
        (key(topic, dds(type_name), type_name), bytes(STORE.serialize_cdr(message, type_name)))
        for topic, (type_name, message) in messages(stamp).items()
    ]
    for topic, pose in (("/alpha/odom", np.eye(4)), ("/beta/odom", beta_pose())):
        type_name = "nav_msgs/msg/Odometry"
        out.append(
            (key(topic, dds(type_name), type_name), bytes(STORE.serialize_cdr(odometry(stamp, pose), type_name)))
        )
    return out


async def test_a_robots_pointcloud2_and_depth_image_over_zenoh_grow_the_map(router: Router) -> None:
    await asyncio.to_thread(samples, time.time())  # the shared data is there (or the test skips, naming it)
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,), relay_id="A"))
    running = await start_relay(parse_config(FLEET, "fleet.yaml"), options=options)
    sequence = 0

    async def publish() -> None:
        nonlocal sequence
        while True:  # 2 a second, each stamped as it is sent, until the map has what it needs
            for topic_key, payload in await asyncio.to_thread(samples, time.time()):
                sequence += 1
                router.put(topic_key, payload, sequence)
            await asyncio.sleep(0.5)

    robots = asyncio.create_task(publish())
    try:
        fusion = await fused(running, each=2)
        occupied = await fusion.run(lambda voxels: voxels.occupied())
        health: dict[str, Any] = running.relay.backend.health()
    finally:
        robots.cancel()  # and its last samples through the router before the relay stops
        await asyncio.gather(robots, return_exceptions=True)
        await running.runner.cleanup()
    for entry in health["clouds"].values():  # only what a cloud may meet as the robots start
        assert entry["last_error"] is None or entry["last_error"].startswith(STARTING), entry
    recall, precision = similar(occupied, await asyncio.to_thread(reference))
    assert recall >= 0.99 and precision >= 0.99, (recall, precision)
