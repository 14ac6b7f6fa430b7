"""The simulated depth camera (issue #33): its points lie on the facility's own surfaces, in the map frame, and the sim
backend sends every robot's cloud when robots.yaml has a ``cloud`` section."""

from __future__ import annotations

import asyncio
import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from relay.backends.sim import SimBackend
from relay.config import Cloud, load_config
from relay.fleet.events import CloudEvent, Event
from relay.sim.camera import SimCamera
from relay.sim.depth_camera import RANGE_MAX, SimDepthCamera

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def camera() -> SimCamera:
    return SimCamera.load(ROOT / "scenes" / "facility.glb")


def _in_map(points: Any, pose: Any) -> Any:
    return np.asarray(points, dtype=np.float64) @ pose[:3, :3].T + pose[:3, 3]


def _distance_to(camera: SimCamera, points: Any) -> float:
    """The farthest of ``points`` from the facility's surfaces, metres."""
    _, distance, _ = trimesh.proximity.closest_point(camera.mesh, points)  # type: ignore[no-untyped-call]
    return float(distance.max())


def test_points_lie_on_the_facility(camera: SimCamera) -> None:
    depth = SimDepthCamera(camera)
    scan = depth.scan(3.0, 1.5, 1.5708)  # robot1's start, facing north into the chemical storage
    assert len(scan.points) > depth.lens.width * depth.lens.height // 2
    world = _in_map(scan.points, scan.pose)
    assert _distance_to(camera, world[::7]) < 1e-3
    # The camera is where the robot is, and sees no farther than its range.
    assert np.allclose(scan.pose[:3, 3], [3.0, 1.5, depth.height])
    assert np.linalg.norm(scan.points, axis=1).max() <= RANGE_MAX + 1e-4
    # It looks north: the points lie ahead of the robot, and it sees the floor before it.
    assert (world[:, 1] > 1.5).mean() > 0.99
    assert (np.abs(world[:, 2]) < 1e-3).any()


async def test_sim_backend_sends_every_robots_cloud(camera: SimCamera) -> None:
    config = dataclasses.replace(load_config(ROOT / "robots.yaml"), cloud=Cloud(sim_depth_rate=5.0))
    events: list[Event] = []
    backend = SimBackend(config, events.append)
    await backend.start()
    try:
        for _ in range(200):
            if {e.robot for e in events if isinstance(e, CloudEvent)} == set(config.names):
                break
            await asyncio.sleep(0.05)
    finally:
        await backend.stop()
    clouds = [e for e in events if isinstance(e, CloudEvent)]
    assert {e.robot for e in clouds} == set(config.names)
    for cloud in clouds[:3]:
        world = _in_map(cloud.points, cloud.pose)
        assert _distance_to(camera, world[::11]) < 1e-3


def test_no_cloud_section_no_depth_camera() -> None:
    config = load_config(ROOT / "robots.yaml")
    assert config.cloud is None
    assert SimBackend(config, lambda event: None)._depth_rate == 0.0
