"""Benchmark: the live 3D map (issue #33), on the shared real Velodyne scans (../shared/data/pointcloud/
fast_gicp_velodyne_pair).

- **Fusion**: a 300 000-point cloud (the two scans, each also turned by 90, 180 and 270 degrees about z: a denser
  lidar's scan of a real place; bench/bench_cloud_fusion.py) fused into a map that already holds the place, as a
  robot's tenth scan of a room is, with the robot driving on at 0.5 m/s. Target: at 10 Hz under one core, i.e. the
  thread's CPU per fusion under 100 ms (CPU time, which a shared machine inflates less than wall time). Beside it, the
  two other ways the issue names, timed on the same cloud: a dict of dense 16³ blocks (only its hits, before any
  clearing) and tracing every ray voxel by voxel (sampled on 10 000 rays).
- **Bytes to a client**: the map the two scans make at 5 cm, as the block records a new client is sent first
  (relay/cloud/blocks_wire.py), against the same two scans as raw sensor_msgs/PointCloud2 (CDR: what a ROS subscriber
  receives) and as rosbridge sends them (its JSON, ``data`` in base64: what a browser of the peers gets). Target: the
  map at most a tenth of the raw clouds.

Runs on the machine's CPU alone (no relay process): the fusion's and the encoding's own cost, as the relay's worker
thread pays it.
"""

from __future__ import annotations

import asyncio
import base64
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from relay.cloud.blocks_wire import encode_blocks
from relay.cloud.pcd import read_pcd
from relay.cloud.pointcloud2 import encode_pointcloud2
from relay.cloud.voxels import VoxelMap
from relay.ros.ros_env import typestore

from .bench_cloud_fusion import DATA, dense_cloud, dict_of_blocks, traced_steps, turned, warmed_map
from .common import JsonDict, Report, Settings, fmt, target

NAME = "cloud"
TITLE = "Live 3D map"
#: 10 Hz under one core: the CPU one fusion may take (s).
FUSION_BUDGET_S = 0.1
#: The map's bytes to a client at most this share of the raw clouds'.
BYTES_RATIO = 0.1
VOXEL = 0.05


def fusion(repeat: int) -> JsonDict:
    """The CPU and wall time of each of ``repeat`` fusions of the dense cloud into a warmed map, and the baselines."""
    cloud = dense_cloud()
    voxels = warmed_map(cloud, VOXEL)
    cpu, wall = [], []
    for k in range(repeat):
        pose = turned(0.002 * k)
        pose[:3, 3] = (0.05 * k, 0.0, 0.0)  # the robot drives on at 0.5 m/s, 10 Hz
        start, start_cpu = time.perf_counter(), time.thread_time()
        voxels.integrate(cloud, pose, 10.0 + k)
        wall.append(time.perf_counter() - start)
        cpu.append(time.thread_time() - start_cpu)
    blocks, dict_s = dict_of_blocks(cloud, VOXEL)
    samples, traced_s = traced_steps(cloud, VOXEL)
    return {
        "points": len(cloud),
        "voxels": len(voxels),
        "cpu_ms": [round(1000 * s, 2) for s in cpu],
        "wall_ms": [round(1000 * s, 2) for s in wall],
        "dict_of_blocks": {"blocks": blocks, "cpu_ms": round(1000 * dict_s, 1)},
        "traced_rays": {"samples": samples, "cpu_s_estimate": round(traced_s, 2)},
    }


def scans() -> list[tuple[Any, np.ndarray]]:
    """The two scans (decoded PCD clouds) and each one's pose in the first one's frame."""
    relative = np.loadtxt(DATA / "relative.txt").reshape(4, 4)
    return [(read_pcd(DATA / "251370668.pcd").cloud(), np.eye(4)), (read_pcd(DATA / "251371071.pcd").cloud(), relative)]


def rosbridge_json(fields: Any) -> bytes:
    """The cloud as rosbridge publishes it to a browser: its ``publish`` op with the message as JSON, the uint8[]
    ``data`` in base64 (rosbridge's encoding of byte arrays)."""
    message = {
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "velodyne"},
        "height": fields.height, "width": fields.width,
        "fields": [{"name": f.name, "offset": f.offset, "datatype": f.datatype, "count": 1} for f in fields.fields],
        "is_bigendian": fields.is_bigendian, "point_step": fields.point_step, "row_step": fields.row_step,
        "data": base64.b64encode(fields.data).decode("ascii"), "is_dense": fields.is_dense,
    }  # fmt: skip
    return json.dumps({"op": "publish", "topic": "/velodyne_points", "msg": message}).encode()


def raw_cdr(fields: Any, store: Any) -> bytes:
    """The cloud as sensor_msgs/PointCloud2 CDR, what a ROS subscriber receives."""
    t = store.types
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="velodyne")
    point_fields = [t["sensor_msgs/msg/PointField"](name=f.name, offset=f.offset, datatype=f.datatype, count=1)
                    for f in fields.fields]  # fmt: skip
    message = t["sensor_msgs/msg/PointCloud2"](
        header=header, height=fields.height, width=fields.width, fields=point_fields,
        is_bigendian=fields.is_bigendian, point_step=fields.point_step, row_step=fields.row_step,
        data=np.frombuffer(fields.data, dtype=np.uint8), is_dense=fields.is_dense,
    )  # fmt: skip
    return bytes(store.serialize_cdr(message, "sensor_msgs/msg/PointCloud2"))


def wire_bytes() -> JsonDict:
    """The bytes of the two scans: raw PointCloud2, rosbridge's JSON, and the map they make as block records."""
    store = typestore()
    voxels = VoxelMap(VOXEL, budget_blocks=50_000)
    raw = as_json = 0
    points = 0
    for k, (cloud, pose) in enumerate(scans()):
        fields = encode_pointcloud2(cloud.xyz, intensity=cloud.intensity)
        raw += len(raw_cdr(fields, store))
        as_json += len(rosbridge_json(fields))
        points += len(cloud)
        voxels.integrate(cloud.xyz, pose, float(k))
    start = time.thread_time()
    records = encode_blocks(voxels.changed_since(0).blocks, VOXEL)
    encode_s = time.thread_time() - start
    return {"points": points, "voxels": len(voxels), "raw_pointcloud2": raw, "rosbridge_json": as_json,
            "map_records": len(records), "encode_cpu_ms": round(1000 * encode_s, 2)}  # fmt: skip


async def run(settings: Settings, report: Report) -> JsonDict:
    if not await asyncio.to_thread(Path(DATA).is_dir):
        why = f"the shared Velodyne scans are absent ({DATA})"
        return {"targets": [target("fusion of a 300 000-point cloud", "10 Hz under one core", "n/a", None, why)]}
    fused = await asyncio.to_thread(fusion, int(settings.pick(20, 5)))
    sizes = await asyncio.to_thread(wire_bytes)
    cpu = statistics.median(fused["cpu_ms"])
    wall = statistics.median(fused["wall_ms"])
    report.line(f"fusion of {fused['points']} points: CPU median {cpu:.1f} ms, wall {wall:.1f} ms")
    ratio = sizes["map_records"] / sizes["raw_pointcloud2"]
    report.line(f"bytes: map {sizes['map_records']}, raw {sizes['raw_pointcloud2']}, JSON {sizes['rosbridge_json']}")
    rate = 1000.0 / cpu if cpu > 0 else float("inf")
    return {
        "fusion": fused,
        "bytes": sizes,
        "targets": [
            target(
                f"fusion of a {fused['points']:,}-point cloud into a map of {fused['voxels']:,} voxels (5 cm)",
                f"10 Hz under one core (CPU <= {1000 * FUSION_BUDGET_S:.0f} ms a cloud)",
                f"{fmt(cpu)} ms CPU a cloud (median of {len(fused['cpu_ms'])}; wall {fmt(wall)} ms): "
                f"{fmt(rate)} Hz on one core",
                cpu <= 1000 * FUSION_BUDGET_S,
                "" if cpu <= 1000 * FUSION_BUDGET_S else "the clearing along rays (relay/cloud/rays.py) dominates",
                baseline=(
                    f"a dict of dense 16³ blocks: {fused['dict_of_blocks']['cpu_ms']} ms for its hits alone, before "
                    f"any clearing; tracing every ray at half-voxel steps: about "
                    f"{fused['traced_rays']['cpu_s_estimate']} s"
                ),
            ),
            target(
                f"bytes to a client for the two shared Velodyne scans ({sizes['points']:,} points)",
                f"<= 1/{round(1 / BYTES_RATIO)} of raw PointCloud2",
                f"{sizes['map_records']:,} B: 1/{1 / ratio:.1f} of raw ({sizes['raw_pointcloud2']:,} B)",
                ratio <= BYTES_RATIO,
                "" if ratio <= BYTES_RATIO else "the map keeps a voxel per 5 cm where the scans are sparse",
                baseline=(
                    f"rosbridge's JSON of the same clouds: {sizes['rosbridge_json']:,} B "
                    f"({sizes['rosbridge_json'] / sizes['map_records']:.0f}x the map's); encoding the map: "
                    f"{sizes['encode_cpu_ms']} ms CPU"
                ),
            ),
        ],
    }
