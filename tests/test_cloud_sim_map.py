"""Over the sim (issue #33): three robots driving the demo facility build a 3D map whose occupied voxels lie within
one voxel of the facility's own geometry; the map is kept beside the database and loaded again at start.

A real relay (sim backend, port 0), its real depth cameras and fusion; goals through the backend as the relay sends
them. No browser."""

from __future__ import annotations

import asyncio
import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from relay.cli.options import Options
from relay.cloud.voxels import VoxelMap
from relay.config import Cloud, load_config
from relay.mapping.fusion import MapFusion, map_path
from relay.sim.camera import SimCamera
from tests.conftest import start_relay

ROOT = Path(__file__).resolve().parents[1]
#: Each robot into its room (robots.yaml's start poses are in the corridor, facing north).
GOALS = {"robot1": (3.0, 7.0), "robot2": (9.0, 7.0), "robot3": (15.0, 7.0)}


async def _fused(fusion: MapFusion, count: int, timeout: float = 60.0) -> None:
    for _ in range(int(timeout / 0.1)):
        if fusion.counters.integrated >= count:
            return
        await asyncio.sleep(0.1)
    raise AssertionError(f"{fusion.counters.integrated} clouds fused, expected {count}: {fusion.counters}")


def _farthest_from_facility(points: Any) -> float:
    """The farthest of ``points`` from the facility mesh's surfaces (blocking: seconds for thousands of points)."""
    camera = SimCamera.load(ROOT / "scenes" / "facility.glb")
    _, distance, _ = trimesh.proximity.closest_point(camera.mesh, points)  # type: ignore[no-untyped-call]
    return float(distance.max())


async def test_three_robots_map_the_facility(tmp_path: Path) -> None:
    config = dataclasses.replace(load_config(ROOT / "robots.yaml"), cloud=Cloud(sim_depth_rate=5.0))
    database = str(tmp_path / "inspection.sqlite")
    running = await start_relay(config, options=Options(backend="sim", database=database))
    relay = running.relay
    try:
        fusion = relay.fusion
        assert fusion is not None
        for robot, (x, y) in GOALS.items():
            await relay.backend.send_goal(robot, x, y, None)
        await _fused(fusion, 45)  # some 3 s of driving, 15 clouds a robot
        occupied: Any = await fusion.run(lambda voxels: voxels.occupied())
        voxel = fusion.voxel
    finally:
        await running.runner.cleanup()
    assert len(occupied) > 3000
    centres = (occupied + 0.5) * voxel
    # Every room was seen: the map reaches into each robot's room.
    for x, _ in GOALS.values():
        assert ((np.abs(centres[:, 0] - x) < 3.0) & (centres[:, 1] > 3.0)).sum() > 200
    assert await asyncio.to_thread(_farthest_from_facility, centres) <= voxel
    # Saved beside the database at shutdown, and read again as it was.
    path = map_path(database)
    assert path is not None and path.exists()
    saved = await asyncio.to_thread(VoxelMap.load, path)
    assert saved.version == fusion.version and len(saved) > 3000  # as the map was at shutdown (it went on meanwhile)


async def test_the_map_is_loaded_at_start(tmp_path: Path) -> None:
    database = str(tmp_path / "inspection.sqlite")
    path = map_path(database)
    assert path == tmp_path / "inspection.sqlite.voxels.npz"
    saved = VoxelMap(0.05)
    saved.integrate(np.array([[2.0, 0.0, 0.0], [2.0, 0.1, 0.0]], np.float32), np.eye(4), 1.0)
    await asyncio.to_thread(saved.save, path)
    fusion = MapFusion(Cloud(), path)
    await fusion.start()
    try:
        assert fusion.version == saved.version
        assert len(await fusion.run(lambda voxels: voxels.occupied())) == 2
    finally:
        await fusion.stop()


async def test_an_unreadable_file_is_moved_aside(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "db.voxels.npz"
    await asyncio.to_thread(VoxelMap(0.1).save, path)  # another voxel size than robots.yaml's
    fusion = MapFusion(Cloud(voxel=0.05), path)
    await fusion.start()
    await fusion.stop()
    assert fusion.version == 0
    assert (tmp_path / "db.voxels.npz.unreadable").exists()
    assert "0.1 m voxels, robots.yaml asks for 0.05" in caplog.text


def test_map_path_is_beside_a_sqlite_file_only() -> None:
    assert map_path(None) is None
    assert map_path("postgresql://u@host/db") is None
    assert map_path("/var/lib/xr/inspection.db") == Path("/var/lib/xr/inspection.db.voxels.npz")


def test_newest_cloud_per_robot_waits() -> None:
    from relay.fleet.events import CloudEvent

    fusion = MapFusion(Cloud(), None)
    points, pose = np.zeros((1, 3), np.float32), np.eye(4)
    for robot in ("robot1", "robot2", "robot1", "robot1"):
        fusion.submit(CloudEvent(robot, 1.0, points, pose))
    assert fusion.counters.dropped == 2
    assert list(fusion._pending) == ["robot1", "robot2"]


async def test_a_bad_cloud_is_named_and_the_next_one_fused() -> None:
    from relay.fleet.events import CloudEvent

    fusion = MapFusion(Cloud(), None)
    await fusion.start()
    try:
        fusion.submit(CloudEvent("robot1", 1.0, np.zeros((5, 2), np.float32), np.eye(4)))
        points = np.array([[2.0, 0.0, 0.0], [np.nan, 0.0, 0.0]], np.float32)
        fusion.submit(CloudEvent("robot2", 1.0, points, np.eye(4)))
        for _ in range(100):
            if fusion.counters.integrated + fusion.counters.failed == 2:
                break
            await asyncio.sleep(0.02)
        health = fusion.health()
        assert health["failed"] == 1 and health["integrated"] == 1 and health["version"] == 1
        assert health["last_failure"] == "robot1's cloud of 5 points: points of shape (5, 2), expected (N, 3)"
        assert len(await fusion.run(lambda voxels: voxels.occupied())) == 1  # the NaN point left out
    finally:
        await fusion.stop()
