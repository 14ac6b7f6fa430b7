"""Voxel map fusion (issue #33): how long relay/cloud/voxels.py takes to fuse a 300 000-point cloud, and how long
tracing its rays voxel by voxel would (why relay/cloud/rays.py asks the question the other way round), and how long
hitting a dict of dense blocks (the other structure issue #33 names) takes before any clearing (why the map is sorted
arrays).

The cloud is the two shared real Velodyne scans (../shared/data/pointcloud/fast_gicp_velodyne_pair), each also
turned by 90, 180 and 270 degrees about z, cut to 300 000 points: a denser lidar's scan of a real place. The map is
warmed with the same clouds first, so each timed fusion clears and hits a map that already holds the place, as a
robot's tenth scan of a room does. Prints the figures (not yet part of bench/run.py's report): wall time, and the
thread's CPU time, which a machine shared with other work inflates less.

    .venv/bin/python -m bench.bench_cloud_fusion [--repeat 20]
"""

from __future__ import annotations

import argparse
import logging
import math
import statistics
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from relay.cloud.pcd import read_pcd
from relay.cloud.voxel_keys import LOCAL_BITS, voxel_keys
from relay.cloud.voxels import VoxelMap

DATA = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "pointcloud" / "fast_gicp_velodyne_pair"
POINTS = 300_000
logger = logging.getLogger("bench_cloud_fusion")


def turned(angle: float) -> NDArray[np.float64]:
    pose = np.eye(4)
    c, s = math.cos(angle), math.sin(angle)
    pose[:2, :2] = [[c, -s], [s, c]]
    return pose


def dense_cloud() -> NDArray[np.float32]:
    relative = np.loadtxt(DATA / "relative.txt").reshape(4, 4)
    target = read_pcd(DATA / "251370668.pcd").cloud().xyz
    source = read_pcd(DATA / "251371071.pcd").cloud().xyz @ relative[:3, :3].T.astype(np.float32)
    parts = [
        cloud @ turned(k * math.pi / 2)[:3, :3].T.astype(np.float32) for k in range(4) for cloud in (target, source)
    ]
    return np.concatenate(parts)[:POINTS].astype(np.float32)


def warmed_map(cloud: NDArray[np.float32], voxel: float, enough: int | None = None) -> VoxelMap:
    """A map that already holds the place: the cloud fused three times from headings a little apart (as a robot
    turning on the spot sees it), or fewer once it holds ``enough`` voxels."""
    voxels = VoxelMap(voxel, budget_blocks=50_000)
    for k in range(3):
        voxels.integrate(cloud, turned(0.01 * k), float(k))
        if enough is not None and len(voxels) >= enough:
            break
    return voxels


def traced_steps(cloud: NDArray[np.float32], voxel: float) -> tuple[int, float]:
    """Samples every half voxel along 10 000 of the rays (each ray's voxel indices, as a DDA visits them), timed,
    and the whole cloud's count."""
    rays = cloud[:: max(1, len(cloud) // 10_000)]
    lengths = np.linalg.norm(rays, axis=1)
    steps = np.ceil(lengths / (voxel / 2)).astype(np.int64)
    start = time.thread_time()
    ray = np.repeat(np.arange(len(rays)), steps)
    t = (np.arange(int(steps.sum())) - np.repeat(np.cumsum(steps) - steps, steps)) / np.repeat(steps, steps)
    samples = np.floor(rays[ray] * t[:, None].astype(np.float32) / voxel).astype(np.int64)
    np.unique(samples[:, 0] * 1_000_003 + samples[:, 1] * 1009 + samples[:, 2])
    seconds = time.thread_time() - start
    whole = int(np.ceil(np.linalg.norm(cloud, axis=1) / (voxel / 2)).sum())
    return whole, seconds * len(cloud) / len(rays)


def dict_of_blocks(cloud: NDArray[np.float32], voxel: float) -> tuple[int, float]:
    """The other structure the issue names, a dict of dense 16³ blocks, hit by one cloud: only its sort by block and
    the loop over blocks (no clearing), timed, with the blocks touched."""
    blocks: dict[int, NDArray[np.uint8]] = {}
    start = time.thread_time()
    keys = voxel_keys(*(np.floor(cloud[:, axis] / np.float32(voxel)).astype(np.int64) for axis in range(3)))
    keys.sort()
    block = keys >> LOCAL_BITS
    cuts = np.flatnonzero(block[1:] != block[:-1]) + 1
    for part in np.split(keys, cuts):
        hits = blocks.setdefault(int(part[0] >> LOCAL_BITS), np.zeros(4096, dtype=np.uint8))
        local = np.unique(part & 4095)
        hits[local] = np.minimum(hits[local] + 1, 8)
    return len(blocks), time.thread_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=20)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    cloud = dense_cloud()
    voxels = warmed_map(cloud, 0.05)
    times, cpu = [], []
    for k in range(args.repeat):
        pose = turned(0.002 * k)
        pose[:3, 3] = (0.05 * k, 0.0, 0.0)  # the robot drives on at 0.5 m/s, 10 Hz
        start, start_cpu = time.perf_counter(), time.thread_time()
        result = voxels.integrate(cloud, pose, 10.0 + k)
        times.append(time.perf_counter() - start)
        cpu.append(time.thread_time() - start_cpu)  # what the fusion costs when the machine is shared
    ordered = sorted(times)
    logger.info(f"fusion of {len(cloud)} points into {len(voxels)} voxels in {len(voxels.blocks)} blocks:")
    logger.info(
        f"  median {statistics.median(times) * 1000:.1f} ms, p90 {ordered[int(0.9 * len(ordered))] * 1000:.1f} ms,"
    )
    logger.info(
        f"  min {ordered[0] * 1000:.1f} ms over {len(times)} fusions; CPU median {statistics.median(cpu) * 1000:.1f} ms"
    )
    logger.info(f"  last: {result}")
    touched, seconds = dict_of_blocks(cloud, 0.05)
    logger.info(
        f"a dict of dense blocks instead: {touched} blocks hit in {seconds * 1000:.1f} ms CPU, before any clearing"
    )
    steps, seconds = traced_steps(cloud, 0.05)
    logger.info(
        f"tracing every ray at half-voxel steps instead: {steps / 1e6:.0f} million samples, ~{seconds:.1f} s CPU"
    )


if __name__ == "__main__":
    main()
