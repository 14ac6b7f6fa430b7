"""Tests for the simulated world: occupancy grids, floor plan, planner, kinematics, follower, hazards."""

from __future__ import annotations

import itertools
import math
import time
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from relay.config import load_config
from relay.fleet.occupancy import OccupancyGrid, from_map_yaml
from relay.sim.floorplan import FloorPlan, demo_facility, rasterise
from relay.sim.follower import PathFollower
from relay.sim.hazards import HazardSource, SensorField
from relay.sim.kinematics import DiffDriveState, DriveLimits, normalize_angle, step
from relay.sim.planner import NoPathError, Planner, plan_path
from relay.sim.world import PLANNING_RADIUS, ROBOT_RADIUS, SimWorld
from tests.conftest import SHARED_DATA

TB3_MAP = SHARED_DATA / "maps" / "turtlebot3_world" / "map.yaml"

Point = tuple[float, float]


@pytest.fixture(scope="module")
def plan() -> FloorPlan:
    return demo_facility()


@pytest.fixture(scope="module")
def grid(plan: FloorPlan) -> OccupancyGrid:
    return rasterise(plan)


@pytest.fixture(scope="module")
def planner(grid: OccupancyGrid) -> Planner:
    return Planner(grid, 0.25)


def _tb3_map() -> OccupancyGrid:
    if not TB3_MAP.is_file():
        pytest.skip(f"shared turtlebot3_world map not found at {TB3_MAP} (expected ../shared/data beside the repo)")
    return from_map_yaml(TB3_MAP)


def _reachable(free: NDArray[np.bool_], seed: tuple[int, int]) -> NDArray[np.bool_]:
    """4-connected flood fill by repeated dilation (test helper, independent of the planner)."""
    seen = np.zeros_like(free)
    seen[seed] = True
    while True:
        grown = seen.copy()
        grown[1:, :] |= seen[:-1, :]
        grown[:-1, :] |= seen[1:, :]
        grown[:, 1:] |= seen[:, :-1]
        grown[:, :-1] |= seen[:, 1:]
        grown &= free
        if np.array_equal(grown, seen):
            return seen
        seen = grown


# -- occupancy -------------------------------------------------------------


def test_grid_conventions_row0_is_lowest_y() -> None:
    occ = np.zeros((4, 6), dtype=bool)
    occ[0, 5] = True  # lowest row, highest column: south-east corner
    g = OccupancyGrid(-1.0, 2.0, 0.5, occ)
    assert (g.width, g.height) == (6, 4)
    assert g.bounds == pytest.approx((-1.0, 2.0, 2.0, 4.0))
    assert g.world_to_cell(1.9, 2.1) == (0, 5)
    assert g.cell_to_world(0, 5) == pytest.approx((1.75, 2.25))
    assert not g.is_free(1.75, 2.25)
    assert g.is_free(-0.9, 3.9)
    assert not g.in_bounds(2.0, 3.0) and not g.is_free(2.0, 3.0)
    assert not g.in_bounds(math.nan, 3.0)
    assert g.world_to_cell(-1.1, 1.9) == (-1, -1)
    # The grid owns a read-only copy: the caller's array cannot change it.
    occ[0, 0] = True
    assert g.is_free(-0.75, 2.25)
    with pytest.raises(ValueError):
        g.occupied[0, 0] = True


def test_inflate_matches_brute_force_disk() -> None:
    rng = np.random.default_rng(7)
    occ = rng.random((40, 50)) < 0.02
    g = OccupancyGrid(0.0, 0.0, 0.05, occ)
    radius = 0.18  # 3.6 cells
    got = g.inflate(radius).occupied
    rows, cols = np.indices(occ.shape)
    expected = np.zeros_like(occ)
    for r, c in np.argwhere(occ):
        expected |= (rows - r) ** 2 + (cols - c) ** 2 <= (radius / 0.05) ** 2
    assert np.array_equal(got, expected)
    assert g.inflate(0.0) is g


def test_segment_free_and_clearance() -> None:
    occ = np.zeros((20, 20), dtype=bool)
    occ[:, 10] = True  # wall along x in [1.0, 1.1)
    g = OccupancyGrid(0.0, 0.0, 0.1, occ)
    assert g.segment_free(0.1, 0.1, 0.9, 1.9)
    assert not g.segment_free(0.5, 0.5, 1.5, 0.5)
    assert not g.segment_free(0.5, 0.5, 2.5, 0.5)  # leaves the map
    assert g.clearance(0.55, 1.05, 1.0) == pytest.approx(0.5)
    assert g.clearance(0.55, 1.05, 0.2) == pytest.approx(0.2)
    assert g.clearance(-1.0, 1.0, 0.2) == 0.0


def _write_map(tmp_path: Path, pgm: bytes, **fields: object) -> Path:
    (tmp_path / "m.pgm").write_bytes(pgm)
    meta = {
        "image": "m.pgm",
        "resolution": 0.5,
        "origin": [1.0, 2.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    meta.update(fields)
    lines = [f"{key}: {value}" for key, value in meta.items()]
    path = tmp_path / "m.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_from_map_yaml_p5_flips_rows_and_treats_unknown_as_occupied(tmp_path: Path) -> None:
    # 3 wide x 2 high, image order: top row = free, free, occupied;
    # bottom row = unknown (205), free, free.
    pixels = bytes([254, 254, 0, 205, 254, 254])
    path = _write_map(tmp_path, b"P5\n# made by a test\n3 2\n255\n" + pixels)
    g = from_map_yaml(path)
    assert (g.width, g.height, g.resolution) == (3, 2, 0.5)
    assert (g.origin_x, g.origin_y) == (1.0, 2.0)
    # ROS order: row 0 is the bottom image row.
    assert g.occupied.tolist() == [[True, False, False], [False, False, True]]
    assert not g.is_free(2.25, 2.75)  # top-right pixel (occupied)
    assert not g.is_free(1.25, 2.25)  # bottom-left pixel (unknown)


def test_from_map_yaml_p2_negate_and_16bit(tmp_path: Path) -> None:
    path = _write_map(tmp_path, b"P2\n2 1\n1000\n0 1000\n", negate=1)
    g = from_map_yaml(path)
    # negate: dark = free.
    assert g.occupied.tolist() == [[False, True]]
    path = _write_map(tmp_path, b"P5 2 1 65535\n" + bytes([0xFF, 0xFF, 0x00, 0x00]))
    assert from_map_yaml(path).occupied.tolist() == [[False, True]]


@pytest.mark.parametrize(
    ("image", "fields", "fragment"),
    [
        (b"P6\n1 1\n255\n\x00\x00\x00", {}, "not a PGM"),
        (b"P5\n4 4\n255\n\x00\x00", {}, "truncated"),
        (b"P2\n2 1\n255\n0 x\n", {}, "non-numeric"),
        (b"P2\n1 1\n255\n0\n", {"resolution": -1}, "resolution"),
        (b"P2\n1 1\n255\n0\n", {"origin": "[0, 0, 1.0]"}, "rotated"),
        (b"P2\n1 1\n255\n0\n", {"mode": "fancy"}, "mode"),
        (b"P2\n1 1\n255\n0\n", {"image": "missing.pgm"}, "missing.pgm"),
    ],
)
def test_from_map_yaml_rejects_bad_input(
    tmp_path: Path, image: bytes, fields: dict[str, object], fragment: str
) -> None:
    path = _write_map(tmp_path, image, **fields)
    with pytest.raises(ValueError, match=fragment) as info:
        from_map_yaml(path)
    assert "m.yaml" in str(info.value) or ".pgm" in str(info.value)


def test_from_map_yaml_missing_file_and_field(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"nope\.yaml"):
        from_map_yaml(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("image: m.pgm\nresolution: 0.05\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"bad\.yaml.*origin"):
        from_map_yaml(bad)


def test_from_map_yaml_turtlebot3_world() -> None:
    g = _tb3_map()
    assert (g.width, g.height) == (384, 384)
    assert g.resolution == pytest.approx(0.05)
    assert (g.origin_x, g.origin_y) == (-10.0, -10.0)
    assert g.bounds == pytest.approx((-10.0, -10.0, -10.0 + 384 * 0.05, -10.0 + 384 * 0.05))
    free_fraction = 1.0 - float(g.occupied.mean())
    # A small explored arena inside a large unknown canvas.
    assert 0.01 < free_fraction < 0.5
    border = np.concatenate(
        [g.occupied[:20].ravel(), g.occupied[-20:].ravel(), g.occupied[:, :20].ravel(), g.occupied[:, -20:].ravel()]
    )
    assert border.mean() > 0.99
    # The free arena is around the map origin (the world's centre).
    free_rows, free_cols = np.nonzero(~g.occupied)
    cx, cy = g.cell_to_world(int(free_rows.mean()), int(free_cols.mean()))
    assert math.hypot(cx, cy) < 1.0
    # Something a robot can drive between: opposite sides of the arena connect.
    inflated = g.inflate(0.2)
    fr, fc = np.nonzero(~inflated.occupied)
    west = g.cell_to_world(int(fr[np.argmin(fc)]), int(fc.min()))
    east = g.cell_to_world(int(fr[np.argmax(fc)]), int(fc.max()))
    path = plan_path(g, west, east, robot_radius=0.2)
    assert path[0] == west and path[-1] == east


def test_planner_speed_on_turtlebot3_world() -> None:
    g = _tb3_map()
    # Measured: Planner build ~5 ms, plans ~1 ms, full plan_path ~6 ms
    # (2-core dev box); the bound is loose, and CPU time, so a loaded CI box does not flake.
    p = Planner(g, 0.2)
    fr, fc = np.nonzero(~p.inflated.occupied)
    pts = [g.cell_to_world(int(fr[k]), int(fc[k])) for k in np.linspace(0, fr.size - 1, 5).astype(int)]
    begin = time.thread_time()
    for a in pts:
        for b in pts:
            p.plan(a, b)
    assert (time.thread_time() - begin) / 25 < 0.2


# -- floor plan --------------------------------------------------------------


def test_floorplan_layout(plan: FloorPlan) -> None:
    assert (plan.width, plan.depth, plan.wall_thickness) == (18.0, 10.0, 0.2)
    for box in plan.walls:
        assert 0.0 <= box.min_x < box.max_x <= 18.0 and 0.0 <= box.min_y < box.max_y <= 10.0
        assert box.kind == "wall"
    assert sorted(d.centre[0] for d in plan.doors) == pytest.approx([3.0, 9.0, 15.0])
    assert all(d.max_x - d.min_x == pytest.approx(1.4) for d in plan.doors)
    assert plan.room("chemical_storage").title == "Chemical storage"
    assert {r.name for r in plan.rooms} == {"corridor", "chemical_storage", "power_distribution", "plumbing"}
    kinds = [b.kind for b in plan.obstacles]
    assert kinds.count("barrel") == 5 and kinds.count("panel") == 3 and kinds.count("pipe_support") == 1
    leaking = next(b for b in plan.obstacles if b.name == "barrel_leaking")
    assert leaking.centre == pytest.approx((1.0, 8.9))
    assert plan.spawn("robot2").x == 9.0 and plan.spawn("robot2").yaw == pytest.approx(math.pi / 2)


def test_rasterise_walls_occupied_doors_and_rooms_free(plan: FloorPlan, grid: OccupancyGrid) -> None:
    assert (grid.width, grid.height) == (360, 200)
    for box in plan.solids:
        assert not grid.is_free(*box.centre), box.name
    for x, y in [(9.0, 0.1), (9.0, 9.9), (0.1, 5.0), (17.9, 5.0), (4.5, 3.0), (6.0, 6.0), (12.0, 6.0)]:
        assert not grid.is_free(x, y)
    for door in plan.doors:
        cx, cy = door.centre
        for dx in (-0.6, 0.0, 0.6):
            for y in (door.min_y, cy, door.max_y):
                assert grid.is_free(cx + dx, y), door.name
    for room in plan.rooms:
        assert grid.is_free(*room.centre), room.name
    for spawn in plan.spawns:
        assert grid.is_free(spawn.x, spawn.y)
    assert grid.is_free(1.8, 8.2) and grid.is_free(15.6, 7.6)  # spill and puddle are floor


def test_every_open_spot_is_reachable(plan: FloorPlan, grid: OccupancyGrid) -> None:
    drivable = ~grid.inflate(0.25).occupied
    seed = grid.world_to_cell(plan.spawns[0].x, plan.spawns[0].y)
    reached = _reachable(drivable, seed)
    open_spots = ~grid.inflate(1.0).occupied
    assert open_spots.sum() > 1000
    assert not np.any(open_spots & ~reached)


# -- planner -----------------------------------------------------------------


def _assert_valid_path(p: Planner, path: list[Point], start: Point, goal: Point) -> None:
    assert path[0] == start and path[-1] == goal
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        assert p.inflated.segment_free(x0, y0, x1, y1), ((x0, y0), (x1, y1))


def test_plan_from_each_spawn_to_each_room(plan: FloorPlan, planner: Planner) -> None:
    # Measured: Planner build 3-5 ms; these plans 1-12 ms each (mean 2-3 ms) on
    # the 2-core dev box; the assertion only guards against regressions such
    # as losing the coarsening (full resolution is ~10x slower). CPU time: a
    # loaded machine makes the clock's time longer, not the planner's work.
    begin = time.thread_time()
    count = 0
    for spawn in plan.spawns:
        for room in plan.rooms:
            start = (spawn.x, spawn.y)
            path = planner.plan(start, room.centre)
            _assert_valid_path(planner, path, start, room.centre)
            count += 1
    assert (time.thread_time() - begin) / count < 0.05


def test_plan_goes_through_the_door(planner: Planner) -> None:
    path = planner.plan((9.0, 1.5), (3.0, 6.0))
    _assert_valid_path(planner, path, (9.0, 1.5), (3.0, 6.0))
    # Densify: the door crossing may lie between two waypoints.
    dense = [
        (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
        for (x0, y0), (x1, y1) in itertools.pairwise(path)
        for t in np.linspace(0.0, 1.0, 50)
    ]
    crossing = [(x, y) for x, y in dense if 2.5 <= y <= 3.5]
    assert crossing and all(abs(x - 3.0) < 0.7 for x, _ in crossing)
    assert any(2.5 <= y <= 3.5 and abs(x - 3.0) < 0.7 for x, y in path)


def test_plan_rejects_bad_goals(grid: OccupancyGrid, planner: Planner) -> None:
    with pytest.raises(NoPathError, match=r"goal \(6\.00, 6\.00\) is inside an obstacle"):
        planner.plan((3.0, 1.5), (6.0, 6.0))
    with pytest.raises(NoPathError, match="robot radius"):
        planner.plan((3.0, 1.5), (6.25, 6.0))
    with pytest.raises(NoPathError, match="outside the map"):
        planner.plan((3.0, 1.5), (30.0, 6.0))
    with pytest.raises(NoPathError, match="inside an obstacle"):
        plan_path(grid, (3.0, 1.5), (16.8, 8.5))


def test_plan_unreachable_goal() -> None:
    occ = np.zeros((60, 60), dtype=bool)
    occ[20:40, 20] = occ[20:40, 39] = occ[20, 20:40] = occ[39, 20:40] = True  # closed box
    g = OccupancyGrid(0.0, 0.0, 0.05, occ)
    with pytest.raises(NoPathError, match=r"no path from \(0\.30, 0\.30\) to \(1\.50, 1\.50\)"):
        plan_path(g, (0.3, 0.3), (1.5, 1.5), robot_radius=0.1)


def test_plan_trivial_and_blocked_door() -> None:
    g = rasterise(demo_facility())
    p = Planner(g)
    assert p.plan((3.0, 1.5), (3.0, 1.5)) == [(3.0, 1.5), (3.0, 1.5)]
    assert p.plan((3.0, 1.5), (3.05, 1.52)) == [(3.0, 1.5), (3.05, 1.52)]
    occ = g.occupied.copy()
    occ[55:65, 40:80] = True  # brick up the chemical storage door (x 2..4, y 2.75..3.25)
    bricked = Planner(OccupancyGrid(0.0, 0.0, 0.05, occ))
    with pytest.raises(NoPathError, match="not reachable"):
        bricked.plan((9.0, 1.5), (3.0, 6.5))


def test_the_sim_plans_around_the_other_robots_and_names_one_in_the_way() -> None:
    world = SimWorld(load_config(Path(__file__).resolve().parent.parent / "robots.yaml"), lambda *_: None)
    # robot1 (3, 1.5) to the corridor's east end, past robot2 (9, 1.5) and robot3 (15, 1.5): around them.
    path = world.plan("robot1", 16.8, 1.5)
    dense = [
        (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
        for (x0, y0), (x1, y1) in itertools.pairwise(path)
        for t in np.linspace(0.0, 1.0, 40)
    ]
    for other in ((9.0, 1.5), (15.0, 1.5)):
        assert min(math.dist(p, other) for p in dense) >= ROBOT_RADIUS + PLANNING_RADIUS - 0.08, path
    assert world.planner.plan((3.0, 1.5), (16.8, 1.5)) == [(3.0, 1.5), (16.8, 1.5)]  # the walls alone: straight
    with pytest.raises(NoPathError, match=r"to \(9\.00, 1\.90\): the goal is next to robot2$"):
        world.plan("robot1", 9.0, 1.9)
    # robot2 parked in chemical storage's door: robot1 cannot get in, and is told why.
    world.robots["robot2"].state = DiffDriveState(3.0, 3.0, 0.0)
    with pytest.raises(NoPathError, match="other robots block every path to it"):
        world.plan("robot1", 3.0, 6.5)
    with pytest.raises(NoPathError, match="inside an obstacle"):  # the walls' own reasons stay theirs
        world.plan("robot1", 6.0, 6.0)


def test_plan_from_start_touching_a_wall(planner: Planner) -> None:
    start = (0.35, 1.5)  # 0.15 m from the west wall's face: inside the inflated zone
    path = planner.plan(start, (3.0, 1.5))
    assert path[0] == start and path[-1] == (3.0, 1.5)
    assert planner.inflated.is_free(*path[1])
    _assert_valid_path(planner, path[1:], path[1], (3.0, 1.5))


# -- kinematics --------------------------------------------------------------

LIMITS = DriveLimits(max_linear=0.5, max_angular=1.5)


def test_normalize_angle() -> None:
    assert normalize_angle(math.pi) == pytest.approx(math.pi)
    assert normalize_angle(-math.pi) == pytest.approx(math.pi)
    assert normalize_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert normalize_angle(-7.0) == pytest.approx(-7.0 + 2 * math.pi)
    assert -math.pi < normalize_angle(1e3) <= math.pi


def test_step_clamps_and_limits_acceleration() -> None:
    s = DiffDriveState(0.0, 0.0, 0.0)
    s1 = step(s, 10.0, -10.0, 0.1, LIMITS)
    assert s1.linear == pytest.approx(0.1)  # 1.0 m/s^2 * 0.1 s
    assert s1.angular == pytest.approx(-0.3)  # 3.0 rad/s^2 * 0.1 s
    assert (s.x, s.linear) == (0.0, 0.0)  # input untouched
    for _ in range(100):
        s1 = step(s1, 10.0, -10.0, 0.02, LIMITS)
    assert s1.linear == pytest.approx(0.5) and s1.angular == pytest.approx(-1.5)
    assert step(s1, math.nan, math.inf, 1.0, LIMITS).linear == 0.0


def test_reversal_brakes_then_accelerates() -> None:
    s = DiffDriveState(0.0, 0.0, 0.0, linear=0.5)
    assert step(s, -0.5, 0.0, 0.1, LIMITS).linear == pytest.approx(0.25)  # braking at 2.5 m/s^2
    # 0.2 s to brake to zero, then 0.1 s accelerating backwards at 1 m/s^2.
    assert step(s, -0.5, 0.0, 0.3, LIMITS).linear == pytest.approx(-0.1)
    with pytest.raises(ValueError):
        step(s, 0.0, 0.0, -0.1, LIMITS)
    with pytest.raises(ValueError):
        DriveLimits(max_linear=0.0, max_angular=1.0)


def test_stop_from_max_speed_is_quick() -> None:
    s = DiffDriveState(0.0, 0.0, 0.0, linear=LIMITS.max_linear, angular=LIMITS.max_angular)
    elapsed = 0.0
    while s.linear != 0.0 or s.angular != 0.0:
        s = step(s, 0.0, 0.0, 0.01, LIMITS)
        elapsed += 0.01
    assert elapsed < 0.3


def test_arc_integration_matches_closed_form() -> None:
    v, w = 0.4, 0.8
    radius = v / w
    s = DiffDriveState(1.0, 2.0, 0.3, linear=v, angular=w)
    steps = 400
    dt = 2 * math.pi / w / steps  # exactly one revolution in total
    quarter = None
    for i in range(steps):
        s = step(s, v, w, dt, LIMITS)
        if i + 1 == steps // 4:
            quarter = s
    assert (s.x, s.y) == pytest.approx((1.0, 2.0), abs=1e-9)
    assert s.yaw == pytest.approx(0.3, abs=1e-9)
    # A quarter turn from heading 0.3: closed-form position on the circle.
    assert quarter is not None
    exp_x = 1.0 + radius * (math.sin(0.3 + math.pi / 2) - math.sin(0.3))
    exp_y = 2.0 - radius * (math.cos(0.3 + math.pi / 2) - math.cos(0.3))
    assert (quarter.x, quarter.y) == pytest.approx((exp_x, exp_y), abs=1e-9)


def test_straight_line_integration() -> None:
    s = DiffDriveState(0.0, 0.0, math.pi / 4, linear=0.5)
    s = step(s, 0.5, 0.0, 2.0, LIMITS)
    assert (s.x, s.y) == pytest.approx((1.0 / math.sqrt(2), 1.0 / math.sqrt(2)))


def test_bumper_stops_at_wall_and_allows_turning(grid: OccupancyGrid) -> None:
    # Drive north from the corridor straight at the corridor wall (y 2.9..3.1).
    s = DiffDriveState(5.0, 1.5, math.pi / 2)
    for _ in range(500):
        s = step(s, 0.5, 0.0, 0.02, LIMITS, grid, radius=0.2)
    assert 2.6 < s.y < 2.9
    assert grid.clearance(s.x, s.y, 1.0) >= 0.2
    assert s.linear == 0.0
    yaw_before = s.yaw
    turned = step(s, 0.5, 1.0, 0.1, LIMITS, grid)
    assert turned.yaw != yaw_before
    # Backing away is allowed.
    back = s
    for _ in range(10):
        back = step(back, -0.3, 0.0, 0.05, LIMITS, grid)
    assert back.y < s.y - 0.05
    # Already-inflated grid with radius=0 behaves the same way at the wall.
    inflated = grid.inflate(0.2)
    s2 = DiffDriveState(5.0, 1.5, math.pi / 2)
    for _ in range(500):
        s2 = step(s2, 0.5, 0.0, 0.02, LIMITS, inflated, radius=0.0)
    assert 2.6 < s2.y < 2.9


# -- follower ----------------------------------------------------------------


def _drive(
    follower: PathFollower, start: DiffDriveState, grid: OccupancyGrid, limit_s: float
) -> tuple[DiffDriveState, float, int]:
    """Close the loop at 50 Hz; returns the final state, time and angular sign flips; asserts no collision."""
    state = start
    t = 0.0
    flips = 0
    last_sign = 0.0
    dt = 0.02
    while t < limit_s:
        linear, angular, done = follower.command(state, LIMITS)
        if done:
            return state, t, flips
        # Ignore numerical dust around zero; count real steering reversals.
        sign = math.copysign(1.0, angular) if abs(angular) > 0.05 else 0.0
        if sign and last_sign and sign != last_sign:
            flips += 1
        last_sign = sign or last_sign
        state = step(state, linear, angular, dt, LIMITS, grid, radius=0.2)
        assert grid.is_free(state.x, state.y), (state.x, state.y)
        t += dt
    raise AssertionError(f"follower did not finish within {limit_s} s, at ({state.x:.2f}, {state.y:.2f})")


def test_follower_closed_loop_spawn_to_every_room(plan: FloorPlan, grid: OccupancyGrid, planner: Planner) -> None:
    for spawn in plan.spawns:
        goals = [r.centre for r in plan.rooms if not r.contains(spawn.x, spawn.y)]
        goals.append((17.0 - spawn.x * 0.9, 1.0))  # far end of the corridor
        for goal, final_yaw in zip(goals, (0.0, 2.5, -2.0, math.pi), strict=True):
            path = planner.plan((spawn.x, spawn.y), goal)
            length = sum(math.dist(a, b) for a, b in itertools.pairwise(path))
            follower = PathFollower(path, final_yaw=final_yaw)
            state, _, flips = _drive(
                follower, DiffDriveState(spawn.x, spawn.y, spawn.yaw), grid, limit_s=length / 0.15 + 20.0
            )
            assert math.dist((state.x, state.y), goal) < 0.2
            assert abs(normalize_angle(state.yaw - final_yaw)) < 0.1
            assert flips <= len(path) + 2, "steering oscillates"
            # Done is latched.
            assert follower.command(state, LIMITS) == (0.0, 0.0, True)


def test_follower_recovers_from_a_bump() -> None:
    # A pillar just above a straight path; the robot starts between them,
    # 0.25 m from the pillar, where heading for the carrot grazes the pillar
    # and the bumper (0.2 m) stops it. Pushing on would deadlock forever.
    g = OccupancyGrid(-2.0, -1.0, 0.05, np.zeros((40, 80), dtype=bool))
    occ = g.occupied.copy()
    (r0, c0), (r1, c1) = g.world_to_cell(-0.15, 0.3), g.world_to_cell(0.149, 0.599)
    occ[r0 : r1 + 1, c0 : c1 + 1] = True
    g = OccupancyGrid(-2.0, -1.0, 0.05, occ)
    follower = PathFollower([(-1.0, 0.0), (1.5, 0.0)])
    state = DiffDriveState(-0.32, 0.17, -0.2)
    bumps = 0
    for _ in range(1500):
        linear, angular, done = follower.command(state, LIMITS)
        if done:
            break
        new = step(state, linear, angular, 0.02, LIMITS, g, radius=0.2)
        bumps += linear > 0.0 and (new.x, new.y) == (state.x, state.y)
        state = new
    assert bumps >= 1, "scenario no longer exercises the bumper"
    assert follower.done and math.dist((state.x, state.y), (1.5, 0.0)) < 0.2


def test_follower_without_final_yaw_and_trivial_path(grid: OccupancyGrid) -> None:
    follower = PathFollower([(3.0, 1.5), (3.0, 2.5)])
    state, _, _ = _drive(follower, DiffDriveState(3.0, 1.5, 0.0), grid, limit_s=20.0)
    assert math.dist((state.x, state.y), (3.0, 2.5)) < 0.2
    only = PathFollower([(3.0, 1.5)], final_yaw=1.0)
    assert only.command(DiffDriveState(3.0, 1.5, 0.0), LIMITS)[2] is False
    with pytest.raises(ValueError):
        PathFollower([])


# -- hazards -----------------------------------------------------------------


def test_concentrations_and_humidity_never_read_negative_temperature_may() -> None:
    fields = SimWorld(load_config(Path(__file__).resolve().parent.parent / "robots.yaml"), lambda *_: None).fields
    rng = np.random.default_rng(7)
    # The corridor's gas is 5 ppm with 2 ppm of noise: unclipped, one reading in 160 would be below zero.
    gas = [fields["gas"].value(3.0, 1.5, rng) for _ in range(5000)]
    assert min(gas) == 0.0 and sum(g == 0.0 for g in gas) < 50
    assert fields["humidity"].minimum == 0.0 and fields["temperature"].minimum is None
    cold = SensorField("temperature", baseline=-5.0, noise=1.0)
    assert min(cold.value(0.0, 0.0, rng) for _ in range(100)) < -5.0


def test_hazard_fields_of_the_demo_fleet() -> None:
    # The demo fleet's fields: baselines from robots.yaml, hazard sources from scenes/facility.yaml.
    fields = SimWorld(load_config(Path(__file__).resolve().parent.parent / "robots.yaml"), lambda *_: None).fields
    rng = np.random.default_rng(3)
    gas, temp, hum = fields["gas"], fields["temperature"], fields["humidity"]
    assert gas.value(1.8, 8.2, rng) > 400 and gas.value(2.3, 7.6, rng) > 400
    assert gas.value(3.0, 1.5, rng) < 100
    assert hum.value(15.6, 7.6, rng) > 70
    for x in (7.8, 9.0, 10.2):
        assert temp.value(x, 9.1, rng) < 35
    assert temp.mean(9.0, 9.1) > temp.mean(9.0, 5.0) > 21.0
    # Smooth falloff: monotone away from the source.
    assert gas.mean(1.8, 8.2) > gas.mean(2.8, 8.2) > gas.mean(3.8, 8.2) > gas.mean(8.0, 8.2)


def test_sensor_field_is_plain_and_noise_is_seeded() -> None:
    f = SensorField("gas", 1.0, 0.5, (HazardSource("gas", 0.0, 0.0, 10.0, 1.0),))
    a = [f.value(0.0, 0.0, np.random.default_rng(9)) for _ in range(2)]
    assert a[0] == a[1]
    assert f.mean(0.0, 0.0) == pytest.approx(11.0)
    with pytest.raises(ValueError):
        HazardSource("gas", 0.0, 0.0, 1.0, 0.0)
