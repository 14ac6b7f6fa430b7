"""What the live backends' cloud tests share (tests/test_cloud_sources_ros.py, _zenoh.py): a fleet of two robots, one
with the shared Velodyne target scan as PointCloud2, one with the first Kinect frame as a 16UC1 depth image and its
CameraInfo, each still at its odometry's pose; the offline reference of their voxels; waiting for the map."""

from __future__ import annotations

import asyncio
import functools
from typing import Any

import numpy as np
from numpy.typing import NDArray

from relay.cloud.pointcloud2 import encode_pointcloud2
from relay.mapping.fusion import MapFusion
from tests.conftest import RunningRelay
from tests.helpers.cloud_messages import (
    KINECT_FRAMES,
    KINECT_K,
    OPTICAL,
    camera_info,
    depth_image,
    kinect_depth,
    pointcloud2,
    reference_voxels,
    velodyne_scans,
)

VOXEL = 0.05
FLEET = f"""
cloud: {{voxel: {VOXEL}, save_every: 3600}}
zenoh: {{domain_id: 0}}
robots:
  - name: alpha
    pose: {{source: odom, base_frame: base_link}}
    limits: {{linear: 0.5, angular: 1.0}}
    scan: null
    clouds:
      - {{name: lidar, pointcloud2: velodyne_points, mount: {{}}}}
  - name: beta
    pose: {{source: odom, base_frame: base_link}}
    limits: {{linear: 0.5, angular: 1.0}}
    scan: null
    clouds:
      - name: kinect
        depth: camera/depth/image_raw
        mount: {{x: 0.1, z: 0.5, roll: -1.5707963267948966, yaw: -1.5707963267948966}}
"""
#: What a cloud may meet as the robots start: it came before the first odometry, or a depth image before its CameraInfo.
STARTING = ("no pose of the robot yet", "no CameraInfo on ")
#: beta's pose: x, y, yaw (alpha is at the origin).
BETA = (-3.0, 2.0, 2.0)
OPTICAL_FRAME = "camera_depth_optical_frame"


def beta_pose() -> NDArray[np.float64]:
    x, y, yaw = BETA
    m = np.eye(4)
    m[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    m[:2, 3] = [x, y]
    return m


@functools.cache
def frames() -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.uint16]]:
    """The Velodyne target scan's points and intensities, and the first Kinect depth frame (read once)."""
    target, intensity, _ = velodyne_scans()[0]
    return target, intensity, kinect_depth(KINECT_FRAMES[0])


def messages(stamp: float) -> dict[str, tuple[str, Any]]:
    """topic -> (type, rosbags message) of the clouds, stamped ``stamp`` (blocking: reads the shared files)."""
    target, intensity, depth = frames()
    return {
        "/alpha/velodyne_points": ("sensor_msgs/msg/PointCloud2",
                                   pointcloud2(encode_pointcloud2(target, intensity=intensity), stamp, "velodyne")),
        "/beta/camera/depth/image_raw": ("sensor_msgs/msg/Image", depth_image(depth, stamp, OPTICAL_FRAME)),
        "/beta/camera/depth/camera_info": ("sensor_msgs/msg/CameraInfo", camera_info(stamp, OPTICAL_FRAME)),
    }  # fmt: skip


def reference() -> set[tuple[int, int, int]]:
    """The voxels of the target scan at the origin and of the Kinect frame at beta's camera (blocking)."""
    target = velodyne_scans()[0][0]
    depth = kinect_depth(KINECT_FRAMES[0])
    fx, _, cx, _, fy, cy = KINECT_K[:6]
    v, u = np.nonzero(depth)
    z = depth[v, u].astype(np.float64) / 1000.0
    kinect = np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=1)
    return reference_voxels([(target, np.eye(4)), (kinect, beta_pose() @ OPTICAL)], VOXEL)


async def fused(running: RunningRelay, each: int, timeout: float = 120.0) -> MapFusion:
    """The fusion once both robots' clouds were decoded ``each`` times and nothing waits (a bounded wait)."""
    fusion = running.relay.fusion
    assert fusion is not None
    health: dict[str, Any] = {}
    for _ in range(int(timeout / 0.1)):
        health = running.relay.backend.health().get("clouds", {})  # type: ignore[assignment]
        decoded = [health.get(k, {}).get("decoded", 0) for k in ("alpha/lidar", "beta/kinect")]
        if min(decoded) >= each and fusion.counters.integrated >= 2 * each and not fusion.health()["waiting"]:
            return fusion
        await asyncio.sleep(0.1)
    raise AssertionError(f"not fused {each} of each within {timeout} s: {fusion.counters}, {health}")


def similar(occupied: NDArray[np.int64], expected: set[tuple[int, int, int]]) -> tuple[float, float]:
    found = {(i, j, k) for i, j, k in occupied.tolist()}
    common = len(found & expected)
    return common / len(expected), common / len(found)
