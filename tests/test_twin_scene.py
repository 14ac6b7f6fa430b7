"""The facility twin (scenes/facility.glb + facility.yaml) and map twins: determinism, validity, frames, content."""

from __future__ import annotations

import importlib.util
import io
import itertools
import math
import subprocess
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
import trimesh
from numpy.typing import NDArray

from relay.config import load_config
from relay.fleet.geometry import yaw_to_quaternion
from relay.fleet.occupancy import OccupancyGrid
from relay.sim.floorplan import FloorPlan, demo_facility, rasterise
from relay.sim.planner import Planner
from relay.twin.facility import Facility, decode_rows, encode_rows, load_facility
from relay.twin.facility_glb import facility_glb
from relay.twin.frames import ROS_TO_GLTF
from relay.twin.gltf import Geometry, Material, Mesh, Node, Primitive, build_glb, read_glb_json
from relay.twin.map_twin import grid_to_glb, map_yaml_layers, ros_map_layers
from tests.conftest import SHARED_DATA
from tests.gltf_validate import issues_text, unavailable_reason, validate_glb

ROOT = Path(__file__).resolve().parents[1]
SHARED = SHARED_DATA
SCENES = ROOT / "scenes"
MAPS = {
    "turtlebot3_world": SHARED / "maps" / "turtlebot3_world" / "map.yaml",
    "depot": SHARED / "maps" / "nav2_bringup" / "depot.yaml",
    "warehouse": SHARED / "maps" / "nav2_bringup" / "warehouse.yaml",
    "tb3_sandbox": SHARED / "maps" / "nav2_bringup" / "tb3_sandbox.yaml",
}
#: The simulator plans with this clearance (relay's sim backend); goals must be reachable with it.
PLANNING_RADIUS = 0.3
MB = 1024 * 1024


def _tool(name: str) -> ModuleType:
    """Import tools/<name>.py without touching sys.path (tools/ is not a package)."""
    spec = importlib.util.spec_from_file_location(f"_tool_{name}", ROOT / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _validate(data: bytes) -> dict[str, Any]:
    reason = unavailable_reason()
    if reason is not None:
        pytest.skip(reason)
    return validate_glb(data)


def _load_scene(data: bytes) -> trimesh.Scene:
    return trimesh.load_scene(io.BytesIO(data), file_type="glb")


def _node_bounds(scene: trimesh.Scene, name: str) -> NDArray[np.float64]:
    """World-space (glTF) bounds ``[[min], [max]]`` of the geometry of node ``name``."""
    transform, geometry_name = scene.graph[name]
    mesh = scene.geometry[geometry_name].copy()
    mesh.apply_transform(transform)
    return np.asarray(mesh.bounds, dtype=np.float64)


def _gltf(x: float, y: float, z: float) -> NDArray[np.float64]:
    point: NDArray[np.float64] = ROS_TO_GLTF @ np.array([x, y, z, 1.0])
    return point[:3]


def _first_hits(mesh: trimesh.Trimesh, xy: NDArray[np.float64], top: float) -> NDArray[np.float64]:
    """glTF height of the first surface hit by a vertical ray down through each ROS point ``(x, y)``."""
    origins = np.stack([xy[:, 0], np.full(len(xy), top), -xy[:, 1]], axis=1)
    directions = np.tile([0.0, -1.0, 0.0], (len(xy), 1))
    locations, index_ray, _ = mesh.ray.intersects_location(origins, directions, multiple_hits=False)
    heights = np.full(len(xy), np.nan)
    heights[index_ray] = locations[:, 1]
    return heights


def _primitive_arrays(data: bytes) -> list[tuple[str, NDArray[np.float32], NDArray[np.float32], NDArray[np.int64]]]:
    """``(mesh name, positions, normals, triangles)`` of every primitive, read straight from the GLB chunks."""
    doc = read_glb_json(data)
    json_length = int.from_bytes(data[12:16], "little")
    blob = data[20 + json_length + 8 :]

    def array(index: int, dtype: str, width: int) -> NDArray[Any]:
        accessor = doc["accessors"][index]
        view = doc["bufferViews"][accessor["bufferView"]]
        start = view["byteOffset"] + accessor.get("byteOffset", 0)
        return np.frombuffer(blob, dtype=dtype, count=accessor["count"] * width, offset=start).reshape(-1, width)

    out = []
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            indices = doc["accessors"][prim["indices"]]
            index_type = "<u2" if indices["componentType"] == 5123 else "<u4"
            out.append(
                (
                    mesh["name"],
                    array(prim["attributes"]["POSITION"], "<f4", 3),
                    array(prim["attributes"]["NORMAL"], "<f4", 3),
                    array(prim["indices"], index_type, 1).reshape(-1, 3).astype(np.int64),
                )
            )
    return out


def _assert_front_faces_outward(data: bytes) -> None:
    """Every triangle is wound counter-clockwise seen from where its normals point (browsers cull the back)."""
    for name, positions, normals, triangles in _primitive_arrays(data):
        a, b, c = (positions[triangles[:, k]].astype(np.float64) for k in range(3))
        winding = np.cross(b - a, c - a)
        shading = normals[triangles].astype(np.float64).sum(axis=1)
        assert ((winding * shading).sum(axis=1) > 0).all(), f"mesh {name} has triangles facing away from their normals"


# -- the facility twin -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def plan() -> FloorPlan:
    return demo_facility()


@pytest.fixture(scope="module")
def glb(plan: FloorPlan) -> bytes:
    return facility_glb(plan)


@pytest.fixture(scope="module")
def facility() -> Facility:
    return load_facility(SCENES / "facility.yaml")


def test_build_is_deterministic_and_committed_files_are_current(tmp_path: Path) -> None:
    # One build in a fresh interpreter (another hash seed, through the CLI) and one in this process.
    proc = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_scene.py"), "--out-dir", str(tmp_path / "a")],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    assert "facility.glb" in proc.stdout and "facility.yaml" in proc.stdout and "bytes" in proc.stdout
    _tool("build_scene").build(tmp_path / "b")
    for name in ("facility.glb", "facility.yaml"):
        fresh = (tmp_path / "a" / name).read_bytes()
        assert fresh == (tmp_path / "b" / name).read_bytes(), f"{name} differs between two builds"
        committed = SCENES / name
        assert committed.is_file(), f"{committed} is missing: run python tools/build_scene.py"
        assert committed.read_bytes() == fresh, f"{committed} is stale: run python tools/build_scene.py"


def test_facility_glb_is_valid_and_small(glb: bytes) -> None:
    assert len(glb) < 2 * MB
    report = _validate(glb)
    assert report["issues"]["numErrors"] == 0, issues_text(report)
    assert report["issues"]["numWarnings"] == 0, issues_text(report)
    # Few draw calls: walls are merged, instances share meshes.
    assert report["info"]["drawCallCount"] <= 30


def test_facility_glb_names_and_materials(glb: bytes, plan: FloorPlan) -> None:
    doc = read_glb_json(glb)
    names = [n["name"] for n in doc["nodes"]]
    expected = {"floor", "wall_north", "wall_south", "wall_east", "wall_west", "spill", "puddle", "pipe", "pipe_leak"}
    expected |= {b.name for b in plan.obstacles}
    assert expected <= set(names), f"missing nodes: {sorted(expected - set(names))}"
    assert len(names) == len(set(names)), "node names must be unique"
    assert names.count("floor") == 1

    materials = doc["materials"]

    def colours(node_name: str) -> list[list[float]]:
        node = next(n for n in doc["nodes"] if n["name"] == node_name)
        prims = doc["meshes"][node["mesh"]]["primitives"]
        return [materials[p["material"]]["pbrMetallicRoughness"]["baseColorFactor"] for p in prims]

    for m in materials:
        assert "baseColorFactor" in m["pbrMetallicRoughness"] and "roughnessFactor" in m["pbrMetallicRoughness"]
    (spill,) = colours("spill")
    assert spill[1] > 0.8 and spill[0] > 0.2 and spill[2] < 0.1  # strong yellow-green
    # ... and used by nothing else, so a camera image can find the spill by its colour.
    spill_index = next(i for i, m in enumerate(materials) if m["pbrMetallicRoughness"]["baseColorFactor"] == spill)
    users = [
        n["name"]
        for n in doc["nodes"]
        if "mesh" in n and any(p["material"] == spill_index for p in doc["meshes"][n["mesh"]]["primitives"])
    ]
    assert users == ["spill"]
    (puddle,) = colours("puddle")
    assert puddle[2] > 0.6 and puddle[2] > 2 * max(puddle[0], puddle[1])  # blue
    panel = colours("panel_1")
    greys = [c for c in panel if max(c[:3]) - min(c[:3]) < 0.1 and 0.3 < c[0] < 0.7]
    yellows = [c for c in panel if c[0] > 0.8 and c[1] > 0.3 and c[2] < 0.1]
    assert greys and yellows, panel
    (floor,) = colours("floor")
    assert max(floor[:3]) - min(floor[:3]) < 0.05 and 0.2 < floor[0] < 0.6  # mid grey
    wall = colours("wall_north")[0]
    assert wall[0] > wall[1] > wall[2] > 0.4  # light beige


def test_facility_glb_is_y_up_in_the_map_frame(glb: bytes, plan: FloorPlan) -> None:
    scene = _load_scene(glb)
    floor = _node_bounds(scene, "floor")
    # The floor covers the footprint at glTF y = 0; ROS +y (north) is glTF -z.
    np.testing.assert_allclose(floor, [[0.0, 0.0, -plan.depth], [plan.width, 0.0, 0.0]], atol=1e-6)
    lo, hi = scene.bounds
    assert lo[1] == pytest.approx(0.0, abs=1e-6) and hi[1] == pytest.approx(2.5, abs=1e-6)  # walls stand on +y

    north = next(w for w in plan.walls if w.name == "wall_north")
    corners = np.array([_gltf(north.min_x, north.min_y, 0.0), _gltf(north.max_x, north.max_y, north.height)])
    np.testing.assert_allclose(_node_bounds(scene, "wall_north"), np.sort(corners, axis=0), atol=1e-5)

    # Semantic nodes sit where the plan puts them.
    leaking = next(b for b in plan.obstacles if b.name == "barrel_leaking")
    barrel = _node_bounds(scene, "barrel_leaking")
    np.testing.assert_allclose(barrel.mean(axis=0)[[0, 2]], _gltf(*leaking.centre, 0.0)[[0, 2]], atol=1e-3)
    assert barrel[1, 1] == pytest.approx(leaking.height, abs=1e-3)
    pipe = _node_bounds(scene, "pipe")
    assert pipe[:, 1].mean() == pytest.approx(2.2, abs=1e-3) and pipe[1, 0] - pipe[0, 0] > 5.0  # along x, overhead
    mesh = scene.to_mesh()
    # Looking straight down: the spill and the puddle lie on the floor under the hazard points,
    # the pipe passes over the puddle, and the floor is bare at the room centres.
    heights = _first_hits(mesh, np.array([[1.8, 8.2], [15.6, 7.25], [15.6, 7.6], [9.0, 6.5]]), 10.0)
    np.testing.assert_allclose(heights[[0, 1]], [0.004, 0.004], atol=1e-3)
    assert heights[2] > 2.0 and heights[3] == pytest.approx(0.0, abs=1e-6)
    spill = _node_bounds(scene, "spill")
    assert spill[0, 0] < 1.8 < spill[1, 0] and spill[0, 2] < -8.2 < spill[1, 2]
    _assert_front_faces_outward(glb)


def test_facility_yaml_matches_the_plan_and_robots_yaml(facility: Facility, plan: FloorPlan) -> None:
    assert facility.glb == SCENES / "facility.glb" and facility.glb.is_file()
    assert facility.up == "Y" and facility.size == (plan.width, plan.depth)
    expected = rasterise(plan, 0.05)
    grid = facility.grid
    assert (grid.origin_x, grid.origin_y, grid.resolution) == (0.0, 0.0, 0.05)
    assert np.array_equal(grid.occupied, expected.occupied)
    assert facility.hazards == plan.hazards and len(facility.hazards) == 5
    assert facility.spawns == plan.spawns and facility.rooms == plan.rooms
    # The simulator's config today repeats the hazards; they must not drift apart.
    config = load_config(ROOT / "robots.yaml")
    if config.sim.hazards:
        assert [(h.kind, h.x, h.y, h.peak, h.sigma) for h in config.sim.hazards] == [
            (h.kind, h.x, h.y, h.peak, h.sigma) for h in facility.hazards
        ]
    for robot in config.robots:
        spawn = facility.spawn(robot.name)
        assert (spawn.x, spawn.y) == pytest.approx((robot.initial_pose.x, robot.initial_pose.y))


def test_facility_grid_walls_doors_and_rooms(facility: Facility, plan: FloorPlan) -> None:
    grid = facility.grid
    for wall in plan.walls:
        for fx in (0.1, 0.5, 0.9):
            x = wall.min_x + fx * (wall.max_x - wall.min_x)
            assert not grid.is_free(x, wall.centre[1]), wall.name
    for obstacle in plan.obstacles:
        assert not grid.is_free(*obstacle.centre), obstacle.name
    for door in plan.doors:
        assert grid.is_free(*door.centre), door.name
        assert grid.is_free(door.centre[0], door.min_y) and grid.is_free(door.centre[0], door.max_y), door.name
    for room in facility.rooms:
        assert grid.is_free(*room.centre), room.name
    # Decals are floor markings: robots drive over the spill and the puddle, which lie at the hazards.
    for decal in plan.decals:
        assert grid.is_free(decal.x, decal.y), decal.name
    spill = next(d for d in plan.decals if d.kind == "spill")
    puddle = next(d for d in plan.decals if d.kind == "puddle")
    leaking = next(b for b in plan.obstacles if b.name == "barrel_leaking")
    assert spill.contains(1.8, 8.2) and spill.contains(*leaking.centre) and not spill.contains(3.0, 6.5)
    assert puddle.contains(15.6, 7.6) and not puddle.contains(15.0, 6.5)
    (pipe,) = plan.pipes
    assert puddle.contains(pipe.leak_x, pipe.y)


def test_every_room_is_reachable_from_every_spawn(facility: Facility) -> None:
    planner = Planner(facility.grid, PLANNING_RADIUS)
    for spawn in facility.spawns:
        for room in facility.rooms:
            goal = room.centre
            path = planner.plan((spawn.x, spawn.y), goal)
            assert path[0] == (spawn.x, spawn.y) and path[-1] == goal, (spawn.robot, room.name)
            length = sum(math.dist(a, b) for a, b in itertools.pairwise(path))
            assert length >= math.dist((spawn.x, spawn.y), goal) - 1e-9


def test_grid_rows_encoding_round_trips() -> None:
    rng = np.random.default_rng(7)
    cells = rng.random((13, 29)) < 0.3
    cells[0, :] = True  # a row starting occupied encodes a leading empty free run
    cells[1, :] = False
    rows = encode_rows(cells)
    assert rows[0] == "0 29" and rows[1] == "29"
    assert np.array_equal(decode_rows(rows, 29, 13), cells)
    with pytest.raises(ValueError, match=r"rows\[2\]"):
        decode_rows([*rows[:2], "3 4", *rows[3:]], 29, 13)


def _broken(tmp_path: Path, old: str, new: str) -> Path:
    text = (SCENES / "facility.yaml").read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "facility.yaml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ("sigma: 1.5", "sigma: -1.5", "hazards[0].sigma"),
        ('{kind: "gas", ', "{", "hazards[0].kind"),
        ("yaw: 1.5707963267948966}", 'yaw: "north"}', "spawns[0].yaw"),
        ("max_x: 18.0, max_y: 3.0", "max_x: -1.0, max_y: 3.0", "rooms[0].bounds"),
        ("width: 360", "width: 359", "grid.rows[0]"),
        ("encoding: rle-rows", "encoding: zlib", "grid.encoding"),
        ("up: Y", "up: Z", "scene.up"),
        ("format: xr-relay-facility/1", "format: other/9", "format"),
        ("  height: 200", "  height: 200\n  colour: red", "grid.colour"),
    ],
)
def test_load_facility_names_file_and_field(tmp_path: Path, old: str, new: str, field: str) -> None:
    path = _broken(tmp_path, old, new)
    with pytest.raises(ValueError) as info:
        load_facility(path)
    assert str(path) in str(info.value) and field in str(info.value)


def test_load_facility_rejects_missing_and_non_yaml_files(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="cannot read"):
        load_facility(tmp_path / "absent.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("grid: [unclosed", encoding="utf-8")
    with pytest.raises(ValueError, match="invalid YAML"):
        load_facility(bad)


# -- the glTF builder -----------------------------------------------------------------------------------


def test_builder_converts_node_transforms_and_accepts_trimesh() -> None:
    """A child 1 m ahead (ROS +x) of a parent at (2, 3, 0) turned 90 degrees left ends up at ROS (2, 4)."""
    cube = Geometry.from_trimesh(trimesh.creation.box(extents=(0.2, 0.2, 0.2)))
    mesh = Mesh("cube", (Primitive(cube, Material("red", (0.8, 0.1, 0.1, 1.0))),))
    child = Node("child", mesh, translation=(1.0, 0.0, 0.5))
    parent = Node(
        "parent", None, translation=(2.0, 3.0, 0.0), rotation=yaw_to_quaternion(math.pi / 2), children=(child,)
    )
    data = build_glb([parent, Node("twin", mesh, translation=(-1.0, 0.0, 0.0))])
    assert data == build_glb([parent, Node("twin", mesh, translation=(-1.0, 0.0, 0.0))])
    doc = read_glb_json(data)
    assert len(doc["meshes"]) == 1 and len(doc["accessors"]) == 3  # both nodes share one mesh
    report = _validate(data)
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0, issues_text(report)
    scene = _load_scene(data)
    np.testing.assert_allclose(_node_bounds(scene, "child").mean(axis=0), _gltf(2.0, 4.0, 0.5), atol=1e-6)
    np.testing.assert_allclose(_node_bounds(scene, "twin").mean(axis=0), _gltf(-1.0, 0.0, 0.0), atol=1e-6)
    _assert_front_faces_outward(data)
    with pytest.raises(ValueError, match="unit quaternion"):
        Node("bad", rotation=(0.0, 0.0, 1.0, 1.0))


# -- map twins -------------------------------------------------------------------------------------------


def _map_layers(name: str) -> tuple[OccupancyGrid, NDArray[np.bool_]]:
    path = MAPS[name]
    if not path.is_file():
        pytest.skip(f"shared map {name} not found at {path} (expected ../shared/data beside the repository)")
    return map_yaml_layers(path)


@pytest.mark.parametrize("name", sorted(MAPS))
def test_map_twin_is_valid_and_matches_the_map(name: str) -> None:
    grid, unknown = _map_layers(name)
    walls = grid.occupied & ~unknown
    assert walls.any() and (~grid.occupied).any()
    height = 1.0
    data = grid_to_glb(grid, height, unknown=unknown, name=name)
    assert len(data) < 5 * MB
    report = _validate(data)
    assert report["issues"]["numErrors"] == 0, issues_text(report)
    assert report["issues"]["numWarnings"] == 0, issues_text(report)

    doc = read_glb_json(data)
    # depot's thresholds leave no unknown cell; the other maps are mostly unexplored outside.
    assert [n["name"] for n in doc["nodes"]] == ["floor", "walls"] + (["unknown"] if unknown.any() else [])
    scene = _load_scene(data)
    min_x, min_y, max_x, max_y = grid.bounds
    np.testing.assert_allclose(_node_bounds(scene, "floor"), [[min_x, 0.0, -max_y], [max_x, 0.0, -min_y]], atol=1e-4)
    lo, hi = scene.bounds
    assert lo[1] == pytest.approx(0.0) and hi[1] == pytest.approx(height)

    # Vertical rays down through sampled cell centres: walls at wall height, known floor at 0,
    # unknown cells not walls (the overlay lies 3 mm above the floor).
    rng = np.random.default_rng(1)
    mesh = scene.to_mesh()
    for mask, expected in ((walls, height), (~grid.occupied, 0.0), (unknown, 0.003)):
        rows, cols = np.nonzero(mask)
        if rows.size == 0:
            continue
        pick = rng.choice(rows.size, size=min(300, rows.size), replace=False)
        xy = np.stack(
            [
                grid.origin_x + (cols[pick] + 0.5) * grid.resolution,
                grid.origin_y + (rows[pick] + 0.5) * grid.resolution,
            ],
            axis=1,
        )
        heights = _first_hits(mesh, xy, height + 1.0)
        np.testing.assert_allclose(heights, expected, atol=1e-4, err_msg=f"{name}: rays onto cells at {expected} m")
    _assert_front_faces_outward(data)


def test_walls_are_merged_into_few_faces() -> None:
    occupied = np.zeros((40, 50), dtype=np.bool_)
    occupied[5:15, 10:30] = True  # one solid block of 200 cells
    occupied[30, 3:47] = True  # a one-cell-thick wall
    grid = OccupancyGrid(-1.0, 2.0, 0.1, occupied)
    doc = read_glb_json(grid_to_glb(grid, 0.5))
    walls = next(m for m in doc["meshes"] if m["name"] == "walls")
    # Each block is a top plus four exposed sides: 5 quads of 4 vertices, no interior faces.
    assert doc["accessors"][walls["primitives"][0]["attributes"]["POSITION"]]["count"] == 2 * 5 * 4
    assert "unknown" not in [n["name"] for n in doc["nodes"]]


def test_unknown_cells_are_not_walls_and_live_maps_convert() -> None:
    width, height = 6, 4
    data = np.zeros((height, width), dtype=np.int16)
    data[0, :] = 100  # a wall along the bottom row (row 0 = origin side, as in nav_msgs)
    data[2:, 3:] = -1  # unknown block
    grid, unknown = ros_map_layers(data.ravel().tolist(), width, height, 0.5, 1.0, -1.0)
    assert grid.occupied[0].all() and grid.occupied[2:, 3:].all() and not grid.occupied[1].any()
    assert np.array_equal(unknown, data < 0)
    mesh = _load_scene(grid_to_glb(grid, 2.0, unknown=unknown)).to_mesh()
    xy = np.array([grid.cell_to_world(r, c) for r, c in ((0, 2), (1, 2), (3, 4))])
    np.testing.assert_allclose(_first_hits(mesh, xy, 5.0), [2.0, 0.0, 0.003], atol=1e-4)
    with pytest.raises(ValueError, match="expected 6 x 4"):
        ros_map_layers([0] * 23, width, height, 0.5, 0.0, 0.0)
    with pytest.raises(ValueError, match="unknown mask"):
        grid_to_glb(grid, unknown=np.zeros((2, 2), dtype=np.bool_))


def test_map_to_gltf_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = MAPS["turtlebot3_world"]
    if not path.is_file():
        pytest.skip(f"shared map not found at {path} (expected ../shared/data beside the repository)")
    out = tmp_path / "tb3.glb"
    assert _tool("map_to_gltf").main([str(path), str(out), "--wall-height", "0.5"]) == 0
    text = capsys.readouterr().out
    assert f"{out.stat().st_size:,} bytes" in text
    assert "meshes: 3" in text and "[-10.000, 9.200]" in text
    assert _load_scene(out.read_bytes()).bounds[1][1] == pytest.approx(0.5)
    assert _tool("map_to_gltf").main([str(tmp_path / "missing.yaml"), str(out)]) == 1
    assert "missing.yaml" in capsys.readouterr().err
