"""The voxel map (relay/cloud/voxels.py) on the shared real Velodyne pair: the occupied voxels of both scans (the second
placed by relative.txt) against an offline reference; a person who walks away cleared by the rays through where they
stood; the budget dropping the least recently seen blocks; exactly the changed blocks returned; save and load."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from relay.cloud import voxels as voxels_module
from relay.cloud.errors import CloudError
from relay.cloud.pcd import read_pcd
from relay.cloud.voxels import VoxelMap
from tests.helpers.clouds import (
    KINECT,
    KINECT_FRAMES,
    VELODYNE,
    VELODYNE_SOURCE,
    VELODYNE_TARGET,
    pointcloud_data,
    velodyne_relative,
)

VOXEL = 0.05


def scans() -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float64]]:
    """(target, source, source's pose in the target's frame): the map frame is the target scan's."""
    folder = pointcloud_data(VELODYNE)
    target = read_pcd(folder / VELODYNE_TARGET).cloud().xyz
    source = read_pcd(folder / VELODYNE_SOURCE).cloud().xyz
    return target, source, velodyne_relative()


def placed(points: NDArray[np.float32], pose: NDArray[np.float64]) -> NDArray[np.float64]:
    return points.astype(np.float64) @ pose[:3, :3].T + pose[:3, 3]


def as_set(indices: NDArray[np.int64]) -> set[tuple[int, int, int]]:
    return {(i, j, k) for i, j, k in indices.tolist()}


def test_both_scans_give_the_occupied_voxels_of_an_offline_reference_to_99_percent() -> None:
    target, source, pose = scans()
    voxels = VoxelMap(VOXEL)
    voxels.integrate(target, np.eye(4), now=1.0)
    voxels.integrate(source, pose, now=2.0)
    # The reference: every point's voxel, in float64, with nothing cleared.
    everything = np.concatenate([target.astype(np.float64), placed(source, pose)])
    reference = as_set(np.unique(np.floor(everything / VOXEL).astype(np.int64), axis=0))
    occupied = as_set(voxels.occupied())
    common = len(reference & occupied)
    assert common / len(reference) >= 0.99, (len(reference), len(occupied), common)
    assert common / len(occupied) >= 0.99


#: The Kinect's optical frame (z forward, x right, y down) on a robot whose map is z up, looking along +x.
OPTICAL = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)


def kinect(frame: str) -> NDArray[np.float32]:
    return read_pcd(pointcloud_data(KINECT) / "pcd" / f"frame_{frame}.pcd").cloud().xyz


def voxels_of(points: NDArray[np.float64]) -> set[tuple[int, int, int]]:
    return as_set(np.unique(np.floor(points / VOXEL).astype(np.int64), axis=0))


def test_a_person_in_front_of_the_kinect_who_walks_away_is_cleared_by_the_next_frame() -> None:
    """The real table-top scene; in the first frame someone's arm, 45 cm in front of the camera, across the rays of
    the middle of the picture; the next real frame's rays pass where it was and end on the scene behind."""
    first, second = kinect(KINECT_FRAMES[0]), kinect(KINECT_FRAMES[1])
    middle = (np.abs(first[:, 0]) < 0.3) & (np.abs(first[:, 1]) < 0.15)
    directions = first[middle] / np.linalg.norm(first[middle], axis=1, keepdims=True)
    arm = np.concatenate([directions * np.float32(depth) for depth in (0.45, 0.5, 0.55)])  # 10 cm thick
    arm_voxels = voxels_of(placed(arm, OPTICAL)) - voxels_of(placed(first, OPTICAL))
    voxels = VoxelMap(VOXEL)
    voxels.integrate(np.concatenate([first, arm]), OPTICAL, now=1.0)
    assert arm_voxels <= as_set(voxels.occupied()) and len(arm_voxels) > 40
    result = voxels.integrate(second, OPTICAL, now=1.25)
    assert arm_voxels & as_set(voxels.occupied()) == set()
    assert result.cleared >= len(arm_voxels)
    # The scene itself stays: what both frames saw is still there.
    assert len(voxels_of(placed(first, OPTICAL)) & voxels_of(placed(second, OPTICAL)) - as_set(voxels.occupied())) == 0


def test_a_person_in_the_velodynes_scan_is_mostly_cleared_by_the_next_scan() -> None:
    """Someone 5 m away in the first scan, where the second scan's rays pass (and end at least 8 m away). A lidar's
    rings are 2 cm of angle apart, 10 cm at 5 m: the voxels between two rings' rays are crossed by none of them,
    and stay until a later scan's rings cross them (relay/cloud/rays.py clears what a ray passed through, never
    what it passed beside)."""
    target, source, pose = scans()
    rays = placed(source, pose) - pose[:3, 3]
    distance = np.linalg.norm(rays, axis=1)
    far = distance > 8
    at_five = rays[far] / distance[far, None] * 5
    azimuth = np.arctan2(at_five[:, 1], at_five[:, 0])
    body = (np.abs(azimuth - 0.5) < 0.05) & (at_five[:, 2] > -1.0) & (at_five[:, 2] < 0.6)
    person = (pose[:3, 3] + at_five[body]).astype(np.float32)
    person_voxels = voxels_of(person.astype(np.float64)) - voxels_of(target.astype(np.float64))
    voxels = VoxelMap(VOXEL)
    voxels.integrate(np.concatenate([target, person]), np.eye(4), now=1.0)
    voxels.integrate(source, pose, now=2.0)
    left = person_voxels & as_set(voxels.occupied())
    assert len(person_voxels) > 50 and len(left) <= 0.2 * len(person_voxels), (len(person_voxels), len(left))


def cube(corner: tuple[float, float, float], points: int = 27) -> NDArray[np.float32]:
    """Points filling one 5 cm voxel at ``corner`` (world metres)."""
    side = round(points ** (1 / 3))
    grid = (np.stack(np.meshgrid(*[np.arange(side)] * 3), axis=-1).reshape(-1, 3) + 0.5) / side * VOXEL
    return np.asarray(grid + np.array(corner), dtype=np.float32)


#: A sensor 4 m to the side of the little test clouds, so that no ray of one passes through another.
ASIDE = np.array([[1, 0, 0, 0], [0, 1, 0, 4], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=np.float64)


def test_the_budget_drops_the_least_recently_seen_blocks_first() -> None:
    voxels = VoxelMap(VOXEL, budget_blocks=3)
    block = 16 * VOXEL  # 0.8 m
    for n in range(3):
        voxels.integrate(cube((n * block, -4, 0)), ASIDE, now=float(n))
    voxels.integrate(cube((0, -4, 0)), ASIDE, now=3.0)  # block 0 seen again: block 1 is now the oldest
    result = voxels.integrate(cube((5 * block, -4, 0)), ASIDE, now=4.0)
    assert result.dropped == 1
    assert [voxels.block((n, 0, 0)) is not None for n in (0, 1, 2, 5)] == [True, False, True, True]
    changes = voxels.changed_since(result.version - 1)
    assert {(b.index, len(b.local)) for b in changes.blocks} == {((5, 0, 0), 1), ((1, 0, 0), 0)}  # empty: dropped


def test_changed_since_returns_exactly_the_blocks_touched() -> None:
    voxels = VoxelMap(VOXEL)
    first = voxels.integrate(np.concatenate([cube((0.1, 0.1, 0.1)), cube((2.0, 0.1, 0.1))]), np.eye(4), now=1.0)
    assert {b.index for b in voxels.changed_since(0).blocks} == {(0, 0, 0), (2, 0, 0)}
    # The same voxel again changes nothing a client draws; a new voxel in block (0, 1, 0) does.
    second = voxels.integrate(np.concatenate([cube((0.1, 0.1, 0.1)), cube((0.1, 0.9, 0.1))]), np.eye(4), now=2.0)
    changes = voxels.changed_since(first.version)
    assert changes.version == second.version == first.version + 1 and not changes.reset
    assert [(b.index, b.local.tolist()) for b in changes.blocks] == [((0, 1, 0), [[2, 2, 2]])]
    unchanged = voxels.integrate(cube((0.1, 0.1, 0.1)), np.eye(4), now=3.0)
    assert unchanged.version == second.version and voxels.changed_since(second.version).blocks == ()


def test_a_client_too_far_behind_the_removals_the_map_remembers_starts_over(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(voxels_module, "FORGOTTEN", 10)
    voxels = VoxelMap(VOXEL, budget_blocks=1)
    for n in range(20):  # each new block drops the last one: more removals than the map remembers
        voxels.integrate(cube((n * 0.8 + 0.1, 0.1, 0.1), points=1), np.eye(4), now=float(n))
    assert len(voxels.removed) == 1 + 10 and voxels.horizon > 0
    changes = voxels.changed_since(1)
    assert changes.reset and [len(b.local) for b in changes.blocks] == [1]
    assert not voxels.changed_since(voxels.version - 1).reset


def test_colour_comes_from_the_cloud_or_is_left_to_the_client() -> None:
    voxels = VoxelMap(VOXEL)
    voxels.integrate(cube((0.1, 0.1, 0.1), points=1), np.eye(4), now=1.0, rgb=np.array([[200, 10, 30]], np.uint8))
    voxels.integrate(cube((0.1, 0.3, 0.1), points=1), np.eye(4), now=1.0)
    (block,) = voxels.changed_since(0).blocks
    assert block.rgb.tolist() == [[200, 10, 30], [0, 0, 0]] and block.coloured.tolist() == [True, False]


def test_save_and_load_give_the_same_map_and_a_bad_file_is_named(tmp_path: Path) -> None:
    target, source, pose = scans()
    voxels = VoxelMap(VOXEL)
    voxels.integrate(target, np.eye(4), now=1.0)
    voxels.integrate(source, pose, now=2.0)
    path = tmp_path / "site.npz"
    voxels.save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["site.npz"]  # the temporary file renamed, none left
    loaded = VoxelMap.load(path)
    assert loaded.voxel == VOXEL and np.array_equal(loaded.occupied(), voxels.occupied())
    assert np.array_equal(loaded.block_seen, voxels.block_seen) and loaded.version == voxels.version
    assert loaded.changed_since(1).reset  # a client of before the restart starts over
    loaded.integrate(source, pose, now=3.0)  # and it goes on
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(CloudError, match=f"voxel map {corrupt} is not a readable .npz"):
        VoxelMap.load(corrupt)
    other = tmp_path / "other.npz"
    np.savez(other, keys=np.zeros(3))
    with pytest.raises(CloudError, match="lacks hits, seen"):
        VoxelMap.load(other)
