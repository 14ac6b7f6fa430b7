"""PointCloud2 decoding (relay/cloud/pointcloud2.py): the real Velodyne scan and Kinect frame written as PointCloud2 and
read back, through rosbags' own message type and CDR too; big-endian and float64 layouts, padded rows; NaNs dropped;
and every wrong layout named in a short message."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from relay.cloud.errors import NAME_LIMIT, CloudError
from relay.cloud.pcd import read_pcd
from relay.cloud.pointcloud2 import (
    FLOAT32,
    Cloud,
    PointCloud2Fields,
    PointFieldSpec,
    decode_pointcloud2,
    encode_pointcloud2,
)
from tests.helpers.clouds import KINECT, KINECT_FRAME, VELODYNE, VELODYNE_TARGET, pointcloud_data

STORE = get_typestore(Stores.ROS2_HUMBLE)


def velodyne() -> Cloud:
    return read_pcd(pointcloud_data(VELODYNE) / VELODYNE_TARGET).cloud()


def test_the_velodyne_scan_written_as_pointcloud2_decodes_to_the_same_points_and_intensities() -> None:
    scan = velodyne()
    assert len(scan) == 69088  # PROVENANCE.txt: all finite
    cloud = decode_pointcloud2(encode_pointcloud2(scan.xyz, intensity=scan.intensity))
    assert np.array_equal(cloud.xyz, scan.xyz)
    assert cloud.intensity is not None and scan.intensity is not None
    assert np.array_equal(cloud.intensity, scan.intensity)
    assert cloud.rgb is None


def as_rosbags(fields: PointCloud2Fields) -> Any:
    """The same cloud as rosbags' sensor_msgs/msg/PointCloud2 (Humble's definition)."""
    types = STORE.types
    header = types["std_msgs/msg/Header"](
        stamp=types["builtin_interfaces/msg/Time"](sec=251370668, nanosec=0), frame_id="velodyne"
    )
    point_fields = [
        types["sensor_msgs/msg/PointField"](name=f.name, offset=f.offset, datatype=f.datatype, count=f.count)
        for f in fields.fields
    ]
    return types["sensor_msgs/msg/PointCloud2"](
        header=header,
        height=fields.height,
        width=fields.width,
        fields=point_fields,
        is_bigendian=fields.is_bigendian,
        point_step=fields.point_step,
        row_step=fields.row_step,
        data=np.frombuffer(fields.data, dtype=np.uint8),
        is_dense=fields.is_dense,
    )


def test_a_real_rosbags_message_through_cdr_decodes_to_the_same_points() -> None:
    scan = velodyne()
    message = as_rosbags(encode_pointcloud2(scan.xyz, intensity=scan.intensity))
    cdr = STORE.serialize_cdr(message, "sensor_msgs/msg/PointCloud2")
    cloud = decode_pointcloud2(STORE.deserialize_cdr(cdr, "sensor_msgs/msg/PointCloud2"))
    assert np.array_equal(cloud.xyz, scan.xyz)


def test_the_kinect_frames_packed_rgba_colours_survive_as_an_organized_cloud() -> None:
    frame = read_pcd(pointcloud_data(KINECT) / "pcd" / f"frame_{KINECT_FRAME}.pcd")
    expected = frame.cloud()
    assert expected.rgb is not None
    # Organized, NaN where the Kinect saw nothing (PROVENANCE.txt: 271575 finite of 307200).
    fields = encode_pointcloud2(frame.xyz(), np.zeros((frame.width * frame.height, 3), np.uint8), width=640)
    assert (fields.width, fields.height, fields.is_dense) == (640, 480, False)
    packed = decode_pointcloud2(fields)
    assert len(packed) == 271575 and np.array_equal(packed.xyz, expected.xyz)
    coloured = decode_pointcloud2(encode_pointcloud2(expected.xyz, expected.rgb))
    assert coloured.rgb is not None and np.array_equal(coloured.rgb, expected.rgb)


@pytest.mark.parametrize("big_endian", [False, True])
@pytest.mark.parametrize("float64", [False, True])
def test_big_endian_and_float64_layouts(big_endian: bool, float64: bool) -> None:
    xyz = np.array([[1.5, -2.25, 3.0], [0.1, 0.2, 0.3]], dtype=np.float64)
    rgb = np.array([[255, 0, 10], [1, 2, 3]], dtype=np.uint8)
    fields = encode_pointcloud2(xyz, rgb, big_endian=big_endian, float64=float64)
    assert fields.point_step == (28 if float64 else 16)
    cloud = decode_pointcloud2(fields)
    assert np.array_equal(cloud.xyz, xyz.astype(np.float32))
    assert cloud.rgb is not None and np.array_equal(cloud.rgb, rgb)
    # The first float's first byte: 1.5 is 0x3FF8... in float64, 0x3FC0... in float32.
    assert fields.data[0 if big_endian else (7 if float64 else 3)] == (0x3F)


def test_padding_between_points_and_rows_is_skipped() -> None:
    """A driver may put other fields between x, y, z (Ouster's) and pad its rows: offsets and row_step say where."""
    records = np.zeros((2, 3), dtype=[("x", "<f4"), ("pad", "<u4"), ("y", "<f4"), ("z", "<f4"), ("i", "<u2")])
    records["x"], records["y"], records["z"] = np.arange(6).reshape(2, 3), 10, 20
    rows = np.zeros((2, records.dtype.itemsize * 3 + 5), dtype=np.uint8)
    rows[:, : records.dtype.itemsize * 3] = records.view(np.uint8).reshape(2, -1)
    specs = (PointFieldSpec("x", 0, FLOAT32), PointFieldSpec("y", 8, FLOAT32), PointFieldSpec("z", 12, FLOAT32))
    fields = PointCloud2Fields(specs, records.dtype.itemsize, rows.shape[1], 3, 2, False, True, rows.tobytes())
    cloud = decode_pointcloud2(fields)
    assert cloud.xyz[:, 0].tolist() == list(range(6)) and set(cloud.xyz[:, 1]) == {10}


def test_nan_and_inf_points_are_dropped() -> None:
    xyz = np.array([[1, 2, 3], [np.nan, 0, 0], [0, np.inf, 0], [4, 5, 6]], dtype=np.float32)
    cloud = decode_pointcloud2(encode_pointcloud2(xyz, intensity=np.arange(4, dtype=np.float32)))
    assert cloud.xyz.tolist() == [[1, 2, 3], [4, 5, 6]]
    assert cloud.intensity is not None and cloud.intensity.tolist() == [0, 3]


def good() -> PointCloud2Fields:
    return encode_pointcloud2(np.ones((4, 3), dtype=np.float32))


@pytest.mark.parametrize(
    ("broken", "named"),
    [
        (replace(good(), fields=good().fields[:2]), "no 'z' field"),
        (replace(good(), fields=(*good().fields[:2], PointFieldSpec("z", 10, FLOAT32))), "field 'z' (offset 10"),
        (replace(good(), fields=(*good().fields, PointFieldSpec("w", 0, 99))), "field 'w' has unknown datatype 99"),
        (replace(good(), data=good().data[:-1]), "data is 47 bytes"),
        (replace(good(), row_step=8), "row_step 8"),
        (replace(good(), point_step=0), "point_step is 0"),
        (replace(good(), fields=(*good().fields, PointFieldSpec("n" * 5000, 40, FLOAT32))), "field 'nnnn"),
    ],
)
def test_a_wrong_layout_is_named_in_a_short_message(broken: PointCloud2Fields, named: str) -> None:
    with pytest.raises(CloudError, match=named.replace("(", r"\(")) as caught:
        decode_pointcloud2(broken)
    assert len(str(caught.value)) < 2 * NAME_LIMIT + 100


def test_an_ascii_pcd_reads_as_the_binary_one(tmp_path: Path) -> None:
    """PCD's DATA ascii (what PCL's pcl_convert_pcd_ascii_binary writes): the first points of the Velodyne scan."""
    binary = read_pcd(pointcloud_data(VELODYNE) / VELODYNE_TARGET)
    head = binary.points[:50]
    lines = [" ".join(repr(float(p[name])) for name in ("x", "y", "z", "intensity")) for p in head]
    text = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\n"
        "TYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 50\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 50\nDATA ascii\n"
    )
    path = tmp_path / "head.pcd"
    path.write_text(text + "\n".join(lines) + "\n")
    ascii_cloud = read_pcd(path).cloud()
    assert np.array_equal(ascii_cloud.xyz, binary.cloud().xyz[:50])
    assert ascii_cloud.intensity is not None and np.array_equal(ascii_cloud.intensity, head["intensity"])


def test_a_pcd_this_reader_cannot_read_is_named(tmp_path: Path) -> None:
    path = tmp_path / "odd.pcd"
    path.write_bytes(b"VERSION 0.7\nFIELDS x\nSIZE 4\nTYPE F\nCOUNT 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA lzma\n")
    with pytest.raises(CloudError, match="DATA 'lzma' not read"):
        read_pcd(path)
