"""relay/fleet/vantage.py: where the VR operator starts, on the demo facility and on grids made to test one rule
each."""

from __future__ import annotations

import math

import numpy as np

from relay.fleet.occupancy import OccupancyGrid
from relay.fleet.vantage import HALF_FOV, MAX_CANDIDATES, MAX_ROBOTS, NEAR, SIGHT_BUDGET, vantage
from relay.twin.facility import load_facility
from tests.conftest import ROOT

FACILITY = load_facility(ROOT / "scenes" / "facility.yaml")


def _in_view(v: tuple[float, float, float], robot: tuple[float, float]) -> bool:
    x, y, yaw = v
    return abs(math.remainder(math.atan2(robot[1] - y, robot[0] - x) - yaw, math.tau)) <= HALF_FOV + 1e-6


def test_the_demo_start_sees_the_whole_fleet_in_one_view_with_room_to_stand() -> None:
    robots = {"robot1": (3.0, 1.5), "robot2": (9.0, 1.5), "robot3": (15.0, 1.5)}
    v = vantage(FACILITY.grid, robots)
    assert v is not None and v.sees == ("robot1", "robot2", "robot3")
    for position in robots.values():
        assert _in_view((v.x, v.y, v.yaw), position)
        assert math.dist((v.x, v.y), position) >= NEAR
        assert FACILITY.grid.segment_free(v.x, v.y, *position)
    assert FACILITY.grid.clearance(v.x, v.y, 0.5) >= 0.5
    assert vantage(FACILITY.grid, robots) == v  # deterministic (and cached)


def test_walls_hide_robots_and_the_start_goes_where_most_are_seen() -> None:
    # Two robots in chemical storage, one in plumbing: the start is in chemical storage, facing both.
    robots = {"a": (2.0, 7.0), "b": (4.5, 8.5), "c": (15.0, 6.0)}
    v = vantage(FACILITY.grid, robots)
    assert v is not None and v.sees == ("a", "b")
    assert 0.0 <= v.x <= 6.0 and 3.0 <= v.y <= 10.0, v


def test_robots_spread_wider_than_a_view_are_fitted_most_first() -> None:
    # An empty 20 x 20 m floor, robots north, east, south and west of the middle: no view holds them all, so
    # the start sees as many as one view can, from far enough back.
    grid = OccupancyGrid(0.0, 0.0, 0.1, np.zeros((200, 200), dtype=bool))
    robots = {"n": (10.0, 14.0), "e": (14.0, 10.0), "s": (10.0, 6.0), "w": (6.0, 10.0)}
    v = vantage(grid, robots)
    assert v is not None and len(v.sees) >= 3
    assert all(_in_view((v.x, v.y, v.yaw), robots[name]) for name in v.sees)


def test_no_robot_or_no_room_gives_no_start() -> None:
    assert vantage(FACILITY.grid, {}) is None
    walled = OccupancyGrid(0.0, 0.0, 0.1, np.ones((30, 30), dtype=bool))
    assert vantage(walled, {"a": (1.0, 1.0)}) is None


def test_a_large_site_is_searched_in_bounded_time() -> None:
    # A 200 x 150 m open yard at 0.1 m: 120 000 spots at the demo's spacing; hello is built on the event loop.
    grid = OccupancyGrid(0.0, 0.0, 0.1, np.zeros((1500, 2000), dtype=bool))
    robots = {f"r{i}": (20.0 + 15 * i, 70.0 + (i % 3) * 5) for i in range(8)}
    calls = 0
    real = grid.segment_free

    def counted(*args: float) -> bool:
        nonlocal calls
        calls += 1
        return real(*args)

    object.__setattr__(grid, "segment_free", counted)  # frozen dataclass: count line-of-sight checks
    v = vantage(grid, robots)
    assert v is not None and len(v.sees) >= 4
    assert calls <= MAX_CANDIDATES * len(robots)


def test_a_large_fleet_is_judged_by_a_bounded_sample() -> None:
    # 100 robots on the demo facility (the client benchmark's fleet): every robot against every spot was 44 000
    # lines of sight, 3 s of the event loop for each connecting client's hello.
    from bench.bench_client_frame import grid_spawns

    robots = {f"robot{i + 1}": xy for i, xy in enumerate(grid_spawns(100))}
    calls = 0
    real = FACILITY.grid.segment_free

    def counted(*args: float) -> bool:
        nonlocal calls
        calls += 1
        return real(*args)

    grid = OccupancyGrid(
        FACILITY.grid.origin_x, FACILITY.grid.origin_y, FACILITY.grid.resolution, FACILITY.grid.occupied
    )
    object.__setattr__(grid, "segment_free", counted)
    v = vantage(grid, robots)
    assert v is not None and 1 <= len(v.sees) <= MAX_ROBOTS
    assert set(v.sees) <= set(robots)
    assert grid.clearance(v.x, v.y, 0.5) >= 0.5
    assert calls <= SIGHT_BUDGET
