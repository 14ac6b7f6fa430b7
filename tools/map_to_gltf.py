"""Turn a ROS map (map_server map.yaml + PGM) into a glTF twin: floor plus extruded walls.

    python tools/map_to_gltf.py ../shared/data/maps/nav2_bringup/warehouse.yaml out.glb [--wall-height 1.0]

Occupied cells become walls ``--wall-height`` metres tall; unknown cells stay floor (darkened). The map frame
is the scene frame; the twin is glTF Y-up (see relay/twin/map_twin.py). Prints the size, mesh count and
bounds of what it wrote.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import trimesh  # noqa: E402

from relay.twin.gltf import read_glb_json  # noqa: E402
from relay.twin.map_twin import grid_to_glb, map_yaml_layers  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("map_yaml", type=Path, help="map_server map.yaml")
    parser.add_argument("output", type=Path, help="GLB file to write")
    parser.add_argument("--wall-height", type=float, default=1.0, help="height of the walls in metres (default 1)")
    args = parser.parse_args(argv)
    try:
        begin = time.perf_counter()
        grid, unknown = map_yaml_layers(args.map_yaml)
        data = grid_to_glb(grid, args.wall_height, unknown=unknown, name=args.map_yaml.stem)
        elapsed = time.perf_counter() - begin
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)  # noqa: T201 - CLI output
        return 1
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_bytes(data)

    doc = read_glb_json(data)
    # Bounds from an independent loader, in glTF coordinates (Y-up) as a viewer sees them.
    scene = trimesh.load_scene(io.BytesIO(data), file_type="glb")
    (x0, y0, z0), (x1, y1, z1) = scene.bounds
    min_x, min_y, max_x, max_y = grid.bounds
    meshes = doc.get("meshes", [])
    report = [
        f"wrote {args.output} ({len(data):,} bytes) in {elapsed:.2f} s",
        f"map: {grid.width} x {grid.height} cells @ {grid.resolution:g} m, {int(unknown.sum()):,} unknown",
        f"meshes: {len(meshes)} ({', '.join(m['name'] for m in meshes)})",
        f"map bounds (ROS x, y): [{min_x:.3f}, {max_x:.3f}] x [{min_y:.3f}, {max_y:.3f}]",
        f"glTF bounds (x, y up, z): [{x0:.3f}, {x1:.3f}] x [{y0:.3f}, {y1:.3f}] x [{z0:.3f}, {z1:.3f}]",
    ]
    print("\n".join(report))  # noqa: T201 - CLI output
    return 0


if __name__ == "__main__":
    sys.exit(main())
