"""The sections of the live 3D map: what fusing a cloud costs and what the map costs a client in bytes beside the
clouds it was made of (bench/bench_cloud.py), and the client's frame time with the map drawn
(bench/bench_map_frame.py)."""

from __future__ import annotations

import statistics

from .common import JsonDict, fmt
from .report_page import Page, pct, section, table

CLOUD_DOC = """The live 3D map of issue #33 on the shared real Velodyne scans (bench/bench_cloud.py). **Fusion:** a
300 000-point cloud (the two scans, each also turned about z: a denser lidar's view of a real place) fused into a 5 cm
map that already holds the place, the robot driving on at 0.5 m/s; the thread's CPU per cloud, with the two other ways
issue #33 names timed on the same cloud. **Bytes:** the map the two scans make, as the block records a new client is
sent first (docs/protocol.md, "Voxel map blocks"), beside the same scans as raw sensor_msgs/PointCloud2 (CDR) and as
rosbridge's JSON (`data` in base64).
"""


def cloud_section(page: Page, r: JsonDict) -> None:
    if not section(page, r, CLOUD_DOC):
        return
    fused, sizes = r["fusion"], r["bytes"]
    rows = [
        ["this relay (sorted keys, clearing by range image)", f"{fmt(statistics.median(fused['cpu_ms']))} ms",
         f"{fmt(statistics.median(fused['wall_ms']))} ms"],
        ["a dict of dense 16³ blocks, hits only", f"{fused['dict_of_blocks']['cpu_ms']} ms", ""],
        ["every ray traced at half-voxel steps (estimate)", f"{fused['traced_rays']['cpu_s_estimate']} s", ""],
    ]  # fmt: skip
    page.add(table(["fusion of one cloud", "CPU", "wall"], rows))
    raw = sizes["raw_pointcloud2"]
    as_map = f"this relay's map ({sizes['voxels']:,} voxels)"
    rows = [
        ["raw PointCloud2 (CDR)", f"{raw:,}", "1"],
        ["rosbridge JSON", f"{sizes['rosbridge_json']:,}", f"{sizes['rosbridge_json'] / raw:.2f}"],
        [as_map, f"{sizes['map_records']:,}", f"{sizes['map_records'] / raw:.3f}"],
    ]
    page.add(table(["the two scans as", "bytes", "of raw"], rows))


MAP_FRAME_DOC = """The client's frame time with the live 3D map drawn (bench/bench_map_frame.py): the three robots of a
fleet in the IWER-emulated Quest 3, as the client frame time above measures it, once with a map of 200 000 voxels or
more (the shared Velodyne scans fused at 5 cm, written where the relay keeps its map before it starts: the page is sent
the whole map as it connects) and once with an empty map, in the same run. On SwiftShader (no GPU): the frame rate is
the CPU's rasterising; the app's JavaScript per frame is what the map costs the page itself.
"""


def map_frame_section(page: Page, r: JsonDict) -> None:
    if not section(page, r, MAP_FRAME_DOC):
        return
    rows = []
    for name, figures in r.get("configurations", {}).items():
        if "error" in figures:
            rows.append([name, "failed", figures["error"], "", ""])
            continue
        app = figures["app_ms"]
        rows.append([name, f"{figures['voxels_drawn']:,}", f"{fmt(app['p50'], 2)} / {fmt(app['p95'], 2)}",
                     f"{figures['render_fps']}", pct(figures["relay_cpu"])])  # fmt: skip
    page.add(table(["map", "voxels drawn", "app JS p50 / p95 ms", "frames/s", "relay CPU"], rows))


MAP_BESIDE_DOC = """The poses' latency with the live 3D map streaming beside them (bench/bench_map_beside.py): the pose
fan-out's target cell (100 robots at 30 Hz to 20 clients) with and without a robot's lidar feeding the map (the shared
Velodyne scan, 2 clouds a second, the robot moving on: fused off the relay's loop, the changed blocks streamed to
every client through the hub's map lane), in turns.
"""


def map_beside_section(page: Page, r: JsonDict) -> None:
    if not section(page, r, MAP_BESIDE_DOC):
        return
    rows = []
    for c in r.get("cells", []):
        if "error" in c:
            rows.append(["on" if c.get("map") else "off", "failed", "", "", ""])
            continue
        latency = f"{fmt(c['latency_ms']['p50'], 2)} / {fmt(c['latency_ms']['p99'], 2)}"
        kilobytes = f"{c['bytes_per_client_per_s'] / 1e3:.0f}"
        delivered, cpu = pct(c["delivered_fraction"]), pct(c["cpu"]["server"])
        rows.append(["on" if c["map"] else "off", latency, delivered, kilobytes, cpu])
    page.add(table(["map", "pose p50 / p99 ms", "delivered", "kB/s a client", "relay CPU"], rows))
