"""Voxel blocks on the wire (relay/cloud/blocks_wire.py, docs/protocol.md "Voxel map blocks"): a tiny record's
bytes computed by hand; the shared Velodyne scans through the map and the wire back within half a voxel of every
point, at a tenth of the raw PointCloud2's bytes; colours by height; a broken record named."""

from __future__ import annotations

import numpy as np
import pytest

from relay.cloud.blocks_wire import HEADER, decode_blocks, encode_block, encode_blocks, height_colours
from relay.cloud.errors import CloudError
from relay.cloud.pcd import read_pcd
from relay.cloud.pointcloud2 import encode_pointcloud2
from relay.cloud.voxels import Block, VoxelMap
from tests.helpers.clouds import VELODYNE, VELODYNE_SOURCE, VELODYNE_TARGET, pointcloud_data, velodyne_relative


def tiny() -> Block:
    """Block (1, -2, 0) at version 7: voxel (0, 0, 0) red, voxel (15, 1, 2) green."""
    return Block(
        (1, -2, 0),
        7,
        np.array([[0, 0, 0], [15, 1, 2]], np.uint8),
        np.array([[255, 0, 0], [0, 255, 0]], np.uint8),
        np.array([True, True]),
    )


def test_a_tiny_records_bytes_are_pinned() -> None:
    expected = bytes.fromhex(
        "58525642"  # magic "XRVB"
        "01" "01" "0200"  # layout version 1, flags 1 (colours follow), 2 voxels (uint16 LE)
        "01000000" "feffffff" "00000000"  # block index (1, -2, 0), int32 LE
        "07000000"  # block version 7, uint32 LE
        "cdcc4c3d"  # voxel size 0.05 as float32 (0x3D4CCCCD) LE
        "0000" "120f"  # local indices: (0,0,0) -> 0x0000; (15,1,2) -> 15*256 + 1*16 + 2 = 0x0F12
        "00f8" "e007"  # RGB565: red 0xF800, green 0x07E0
    )  # fmt: skip
    assert HEADER.size == 28
    assert encode_block(tiny(), 0.05) == expected
    (decoded,) = decode_blocks(expected)
    assert (decoded.index, decoded.version, decoded.local.tolist()) == ((1, -2, 0), 7, [[0, 0, 0], [15, 1, 2]])
    assert decoded.rgb is not None and decoded.rgb.tolist() == [[255, 0, 0], [0, 255, 0]]
    assert decoded.centres()[1] == pytest.approx([(16 + 15.5) * 0.05, (-32 + 1.5) * 0.05, 2.5 * 0.05])


def test_a_removed_block_is_a_header_alone_and_records_follow_one_another() -> None:
    empty = Block((3, 0, -1), 9, np.zeros((0, 3), np.uint8), np.zeros((0, 3), np.uint8), np.zeros(0, bool))
    frame = encode_blocks([tiny(), empty], 0.05)
    assert len(frame) == 28 + 2 * 4 + 28
    assert frame[36 + 5] == 0  # an empty block: no colours
    assert [(b.index, len(b.local)) for b in decode_blocks(frame)] == [((1, -2, 0), 2), ((3, 0, -1), 0)]


def test_the_velodyne_scans_come_back_within_half_a_voxel_at_a_tenth_of_the_raw_bytes() -> None:
    folder = pointcloud_data(VELODYNE)
    target = read_pcd(folder / VELODYNE_TARGET).cloud()
    source = read_pcd(folder / VELODYNE_SOURCE).cloud()
    pose = velodyne_relative()
    voxels = VoxelMap(0.05)
    voxels.integrate(target.xyz, np.eye(4), now=1.0)
    voxels.integrate(source.xyz, pose, now=2.0)
    frame = encode_blocks(voxels.changed_since(0).blocks, voxels.voxel)
    centres = np.concatenate([b.centres() for b in decode_blocks(frame)])
    # Every voxel sent is the voxel of a point of the first scan, within half a voxel of it on each axis.
    nearest = {tuple(v) for v in np.floor(target.xyz.astype(np.float64) / 0.05).astype(np.int64).tolist()}
    sent = np.floor(centres / 0.05).astype(np.int64)
    first = np.array([tuple(v) in nearest for v in sent.tolist()])
    points = target.xyz.astype(np.float64)
    keys = {tuple(v): p for v, p in zip(np.floor(points / 0.05).astype(np.int64).tolist(), points, strict=True)}
    offsets = np.array([keys[tuple(v)] for v in sent[first].tolist()]) - centres[first]
    assert np.abs(offsets).max() <= 0.025 + 1e-9
    assert len(centres) == len(voxels)
    # Issue #33's target: at most a tenth of the same scans as PointCloud2 (x, y, z, intensity: 16 bytes a point).
    raw = sum(len(encode_pointcloud2(c.xyz, intensity=c.intensity).data) for c in (target, source))
    assert len(frame) <= raw / 10, (len(frame), raw)


def test_voxels_without_a_colour_are_coloured_by_height() -> None:
    assert height_colours(np.array([-1.0, 0.0, 0.75, 1.5, 3.0, 9.0])).tolist() == [
        [0, 0, 255],
        [0, 0, 255],
        [0, 255, 255],
        [0, 255, 0],
        [255, 0, 0],
        [255, 0, 0],
    ]
    # In a block with colours, a voxel without one gets the ramp's: at -2.5 cm, blue (0x001F).
    mixed = Block((0, 0, -1), 1, np.array([[0, 0, 0], [0, 0, 1]], np.uint8),
                  np.array([[9, 9, 9], [0, 0, 0]], np.uint8), np.array([True, False]))  # fmt: skip
    assert encode_block(mixed, 0.05)[-2:] == bytes.fromhex("1f00")
    # A block without any: local indices alone, the client colours them by the same ramp.
    plain = Block((0, 0, 0), 1, np.array([[0, 0, 0]], np.uint8), np.zeros((1, 3), np.uint8), np.array([False]))
    record = encode_block(plain, 0.05)
    assert len(record) == 28 + 2 and record[5] == 0 and decode_blocks(record)[0].rgb is None


def test_a_broken_record_is_named() -> None:
    good = encode_block(tiny(), 0.05)
    with pytest.raises(CloudError, match="at byte 0: 10 bytes, the header is 28"):
        decode_blocks(good[:10])
    with pytest.raises(CloudError, match="2 voxels need 36 bytes"):
        decode_blocks(good[:-1])
    with pytest.raises(CloudError, match=r"magic b'YRVB' version 1"):
        decode_blocks(b"Y" + good[1:])
