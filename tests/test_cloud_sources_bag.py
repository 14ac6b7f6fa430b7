"""Issue #33's "Done when" over the bag backend: the shared real frames (../shared/data/pointcloud) written as
PointCloud2, 16UC1 depth Image and CameraInfo messages into a rosbag2 with rosbags, replayed by a real relay (port 0)
through robots.yaml's per-robot ``clouds``; the map's occupied voxels match an offline reference computed here from
the same frames with numpy to 99 %. Bad clouds (wrong fields, NaNs only, an unknown encoding, no transform) are
named in the log and in /healthz, and the replay goes on."""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest
from numpy.typing import NDArray

from relay.cli.options import BagOptions, Options
from relay.cloud.pointcloud2 import PointCloud2Fields, PointFieldSpec, encode_pointcloud2
from relay.config import parse_config
from relay.mapping.fusion import MapFusion
from tests.conftest import RunningRelay, start_relay
from tests.helpers.cloud_messages import (
    KINECT_FRAMES,
    KINECT_K,
    OPTICAL,
    Timed,
    camera_info,
    depth_image,
    kinect_depth,
    kinect_organized,
    kinect_pointcloud2,
    odometry,
    pointcloud2,
    reference_voxels,
    tf_static,
    velodyne_scans,
    write_bag,
)

VOXEL = 0.05
#: The recordings' first second (any fixed time: the relay places clouds by their stamps, not by the clock).
T0 = 1_700_000_000.0
ODOM, POINTCLOUD2 = "nav_msgs/msg/Odometry", "sensor_msgs/msg/PointCloud2"
IMAGE, CAMERA_INFO, TF = "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo", "tf2_msgs/msg/TFMessage"

#: Each Kinect frame is its own robot's: the fusion keeps the newest cloud of each robot waiting, and a loaded machine
#: could let a robot's next frame replace one not fused yet. k1-k3 send depth images placed through /tf_static,
#: p1-p3 the organized PCDs as PointCloud2 placed by robots.yaml's mount.
ROBOT_ENTRY = """
  - name: {name}
    pose: {{source: odom, base_frame: base_link}}
    limits: {{linear: 0.5, angular: 1.0}}
    scan: null
    clouds: [{cloud}]"""
DEPTH = "{name: kinect, depth: camera/depth/image_raw}"
POINTS = ("{name: points, pointcloud2: camera/depth/points, "
          "mount: {x: 0.1, z: 0.5, roll: -1.5707963267948966, yaw: -1.5707963267948966}}")  # fmt: skip
KINECT_FLEET = f"cloud: {{voxel: {VOXEL}, save_every: 3600}}\nrobots:" + "".join(
    ROBOT_ENTRY.format(name=f"{kind}{k + 1}", cloud=cloud)
    for kind, cloud in (("k", DEPTH), ("p", POINTS))
    for k in range(3)
)


def pose(x: float, y: float, yaw: float) -> NDArray[np.float64]:
    m = np.eye(4)
    m[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    m[:2, 3] = [x, y]
    return m


ROBOT1, ROBOT2 = pose(2.0, 1.0, 0.3), pose(-3.0, 2.0, 2.0)


def odometry_at(robot: str, where: NDArray[np.float64], until: float) -> list[Timed]:
    """The robot's odometry at 10 Hz from the recording's start to ``until``."""
    return [Timed(T0 + k / 10, f"/{robot}/odom", ODOM, odometry(T0 + k / 10, where))
            for k in range(round((until - T0) * 10) + 1)]  # fmt: skip


def depth_points_by_hand(depth: NDArray[np.uint16]) -> NDArray[np.float64]:
    """The depth image's points in its optical frame, float64, straight from the pinhole (the reference's own)."""
    fx, _, cx, _, fy, cy = KINECT_K[:6]
    v, u = np.nonzero(depth)
    z = depth[v, u].astype(np.float64) / 1000.0
    return np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=1)


async def replay(tmp_path: Path, fleet: str, bag: Path) -> RunningRelay:
    config = parse_config(fleet, "fleet.yaml")
    options = Options(backend="bag", database=str(tmp_path / "db.sqlite"), bag=BagOptions(bags=(str(bag),)))
    return await start_relay(config, options=options)


async def until_done(running: RunningRelay, clouds: int, timeout: float = 120.0) -> MapFusion:
    """The fusion once ``clouds`` clouds reached it and it fused or dropped each (a bounded wait)."""
    fusion = running.relay.fusion
    assert fusion is not None
    for _ in range(int(timeout / 0.1)):
        c = fusion.counters
        if (
            c.received >= clouds
            and c.integrated + c.dropped + c.failed >= c.received
            and not fusion.health()["waiting"]
        ):
            return fusion
        await asyncio.sleep(0.1)
    raise AssertionError(f"the map got {fusion.counters} of {clouds} clouds")


async def healthz(running: RunningRelay) -> dict[str, Any]:
    async with aiohttp.ClientSession() as session, session.get(running.url + "/healthz") as response:
        body: dict[str, Any] = await response.json()
        return body


def similar(occupied: NDArray[np.int64], reference: set[tuple[int, int, int]]) -> tuple[float, float]:
    """(share of the reference in the map, share of the map in the reference)."""
    found = {(i, j, k) for i, j, k in occupied.tolist()}
    common = len(found & reference)
    return common / len(reference), common / len(found)


def kinect_recording(path: Path) -> tuple[Path, list[tuple[NDArray[np.floating[Any]], NDArray[np.float64]]]]:
    """The bag of the Kinect frames, and the reference's clouds (blocking: seconds of reading and writing)."""
    records: list[Timed] = []
    clouds: list[tuple[NDArray[np.floating[Any]], NDArray[np.float64]]] = []
    optical = "camera_depth_optical_frame"
    for k, frame in enumerate(KINECT_FRAMES):
        stamp, depth, kn, pn = T0 + 1.0 + k, kinect_depth(frame), f"/k{k + 1}", f"/p{k + 1}"
        records += [
            Timed(stamp, f"{kn}/camera/depth/image_raw", IMAGE, depth_image(depth, stamp, optical)),
            Timed(stamp - 0.01, f"{kn}/camera/depth/camera_info", CAMERA_INFO, camera_info(stamp, optical)),
            Timed(T0, f"{kn}/tf_static", TF, tf_static(T0, "base_link", optical, OPTICAL)),
            Timed(stamp, f"{pn}/camera/depth/points", POINTCLOUD2, kinect_pointcloud2(frame, stamp)),
            *odometry_at(kn[1:], ROBOT1, T0 + 4),
            *odometry_at(pn[1:], ROBOT2, T0 + 4),
        ]
        clouds += [(depth_points_by_hand(depth), ROBOT1 @ OPTICAL), (kinect_organized(frame)[0], ROBOT2 @ OPTICAL)]
    return write_bag(path, records), clouds


async def test_the_kinect_frames_as_depth_images_and_pointclouds_replayed_match_the_reference(tmp_path: Path) -> None:
    bag, clouds = await asyncio.to_thread(kinect_recording, tmp_path / "kinect")
    running = await replay(tmp_path, KINECT_FLEET, bag)
    try:
        fusion = await until_done(running, 6)
        occupied = await fusion.run(lambda voxels: voxels.occupied())
        health = await healthz(running)
    finally:
        await running.runner.cleanup()
    assert fusion.counters.integrated == 6, fusion.counters
    sources = health["clouds"]
    assert all(sources[f"k{k}/kinect"]["decoded"] == sources[f"p{k}/points"]["decoded"] == 1 for k in (1, 2, 3))
    assert sources["p1/points"]["non_finite"] == 307200 - 271575  # the organized cloud's missing returns (PROVENANCE)
    reference = await asyncio.to_thread(reference_voxels, clouds, VOXEL)
    recall, precision = similar(occupied, reference)
    assert recall >= 0.99 and precision >= 0.99, (recall, precision, len(reference), len(occupied))


VELODYNE_FLEET = f"""
cloud: {{voxel: {VOXEL}, save_every: 3600}}
robots:
  - name: robot1
    pose: odom
    limits: {{linear: 0.5, angular: 1.0}}
    scan: null
    clouds:
      - {{name: lidar, pointcloud2: velodyne_points, mount: {{}}}}
"""


async def test_the_velodyne_pair_replayed_at_its_poses_matches_the_reference(tmp_path: Path) -> None:
    (target, target_intensity, _), (source, source_intensity, relative) = velodyne_scans()
    # One robot, still at the origin until T0 + 2, then where relative.txt puts the second scan, 4 s later: the
    # first is fused long before (some 0.1-0.5 s), so the second never replaces it waiting.
    records = [
        Timed(T0 + 1, "/robot1/velodyne_points", POINTCLOUD2,
              pointcloud2(encode_pointcloud2(target, intensity=target_intensity), T0 + 1, "velodyne")),
        Timed(T0 + 5, "/robot1/velodyne_points", POINTCLOUD2,
              pointcloud2(encode_pointcloud2(source, intensity=source_intensity), T0 + 5, "velodyne")),
    ]  # fmt: skip
    records += [r if r.stamp < T0 + 2 else Timed(r.stamp, r.topic, ODOM, odometry(r.stamp, relative))
                for r in odometry_at("robot1", np.eye(4), T0 + 6)]  # fmt: skip
    bag = await asyncio.to_thread(write_bag, tmp_path / "velodyne", records)
    running = await replay(tmp_path, VELODYNE_FLEET, bag)
    try:
        fusion = await until_done(running, 2)
        occupied = await fusion.run(lambda voxels: voxels.occupied())
    finally:
        await running.runner.cleanup()
    assert fusion.counters.integrated == 2, fusion.counters
    reference = await asyncio.to_thread(reference_voxels, [(target, np.eye(4)), (source, relative)], VOXEL)
    recall, precision = similar(occupied, reference)
    assert recall >= 0.99 and precision >= 0.99, (recall, precision)


BAD_FLEET = f"""
cloud: {{voxel: {VOXEL}, save_every: 3600}}
robots:
  - name: robot1
    pose: odom
    limits: {{linear: 0.5, angular: 1.0}}
    scan: null
    clouds:
      - {{name: fields, pointcloud2: fields, rate: 10, mount: {{}}}}
      - {{name: nans, pointcloud2: nans, rate: 10, mount: {{}}}}
      - {{name: untransformed, pointcloud2: untransformed, rate: 10}}
      - {{name: late, pointcloud2: late, rate: 10, mount: {{}}}}
      - {{name: yuv, depth: yuv/image_raw, rate: 10, mount: {{}}}}
      - {{name: good, pointcloud2: good, rate: 10, mount: {{}}}}
"""


def no_z(stamp: float) -> Any:
    """A cloud whose fields lack ``z``: x, y and intensity only."""
    fields = encode_pointcloud2(np.ones((10, 3), np.float32), intensity=np.ones(10, np.float32))
    broken = PointCloud2Fields(
        (PointFieldSpec("x", 0, 7), PointFieldSpec("y", 4, 7), PointFieldSpec("intensity", 12, 7)),
        fields.point_step, fields.row_step, fields.width, fields.height, False, True, fields.data,
    )  # fmt: skip
    return pointcloud2(broken, stamp, "base_link")


async def test_bad_clouds_are_named_in_the_log_and_the_health_and_the_good_one_is_fused(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger="relay.backends.cloud_intake")
    points = np.array([[1.0, 0.0, 0.5], [1.0, 0.2, 0.5], [2.0, 0.0, 0.3]], np.float32)
    stamp = T0 + 1
    records = [
        Timed(stamp, "/robot1/fields", POINTCLOUD2, no_z(stamp)),
        Timed(stamp, "/robot1/nans", POINTCLOUD2,
              pointcloud2(encode_pointcloud2(np.full((5, 3), np.nan, np.float32)), stamp, "base_link")),
        Timed(stamp, "/robot1/untransformed", POINTCLOUD2,
              pointcloud2(encode_pointcloud2(points), stamp, "lidar_link")),
        Timed(stamp, "/robot1/late", POINTCLOUD2, pointcloud2(encode_pointcloud2(points), T0 + 60, "base_link")),
        Timed(stamp, "/robot1/yuv/image_raw", IMAGE, depth_image(np.ones((4, 4), np.uint16), stamp, "c", "yuv422")),
        Timed(stamp, "/robot1/yuv/camera_info", CAMERA_INFO, camera_info(stamp, "c", 4, 4)),
        Timed(stamp, "/robot1/good", POINTCLOUD2, pointcloud2(encode_pointcloud2(points), stamp, "base_link")),
        *odometry_at("robot1", np.eye(4), T0 + 2),
    ]  # fmt: skip
    running = await replay(tmp_path, BAD_FLEET, await asyncio.to_thread(write_bag, tmp_path / "bad", records))
    try:
        fusion = await until_done(running, 1)
        health = await healthz(running)
        for _ in range(100):  # every source's message was read by the end of the bag
            health = await healthz(running)
            if sum(s["decoded"] + s["failed"] for s in health["clouds"].values()) >= 6:
                break
            await asyncio.sleep(0.1)
    finally:
        await running.runner.cleanup()
    assert fusion.counters.integrated == 1 and health["status"] == "ok"
    sources = health["clouds"]
    assert sources["robot1/good"]["decoded"] == 1 and sources["robot1/good"]["last_error"] is None
    expected = {
        "fields": "PointCloud2 has no 'z' field",
        "nans": "all 5 points are NaN or infinite",
        "untransformed": "no transform from frame 'lidar_link' to the robot's base frame 'base_footprint'",
        "late": "no transform at the cloud's stamp 1700000060.000",
        "yuv": "depth image encoding 'yuv422' is not one of 16UC1, 32FC1",
    }
    for name, why in expected.items():
        entry = sources[f"robot1/{name}"]
        assert entry["failed"] == 1 and entry["decoded"] == 0 and why in entry["last_error"], (name, entry)
        assert any(f"robot1 cloud {name} on /robot1/" in r.getMessage() and why in r.getMessage()
                   for r in caplog.records), name  # fmt: skip
