"""Depth images to points (relay/cloud/depth.py): the real Kinect depth TIFF and its intrinsics give the points of the
organized PCD PCL wrote of the same frame, within a millimetre; as a sensor_msgs/Image of either encoding and byte
order; decimated; an unknown encoding or a short image named."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray
from rosbags.typesys import Stores, get_typestore

from relay.cloud.depth import DepthPoints, Pinhole, depth_points, image_points
from relay.cloud.errors import CloudError
from relay.cloud.pcd import read_pcd
from tests.helpers.clouds import KINECT, KINECT_FRAME, pointcloud_data

STORE = get_typestore(Stores.ROS2_HUMBLE)


def kinect_pinhole() -> tuple[Pinhole, float]:
    """The depth camera's intrinsics and unit, from the frame's own pclzf/frame_<ts>.xml (PCL's ImageGrabber reads
    them there; PROVENANCE.txt: fx = fy = 525, cx = 320, cy = 240, z_multiplication_factor 0.001)."""
    text = (pointcloud_data(KINECT) / "pclzf" / f"frame_{KINECT_FRAME}.xml").read_text()
    # Two top-level elements (<rgb>, <depth>), as PCL writes them: wrapped to parse as one document.
    depth = ET.fromstring("<frame>" + text.split("?>", 1)[1] + "</frame>").find("depth")
    assert depth is not None

    def value(tag: str) -> float:
        return float(depth.findtext(tag) or "nan")

    pinhole = Pinhole(value("focal_length_x"), value("focal_length_y"),
                      value("principal_point_x"), value("principal_point_y"))  # fmt: skip
    return pinhole, value("z_multiplication_factor")


def kinect_depth() -> NDArray[np.uint16]:
    path = pointcloud_data(KINECT) / "tiff" / f"frame_{KINECT_FRAME}_depth.tiff"
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert image is not None and image.dtype == np.uint16 and image.shape == (480, 640)
    return np.asarray(image, dtype=np.uint16)


def assert_matches_the_pcd(points: DepthPoints) -> None:
    organized = read_pcd(pointcloud_data(KINECT) / "pcd" / f"frame_{KINECT_FRAME}.pcd").xyz()
    finite = np.isfinite(organized).all(axis=1)
    assert np.array_equal(np.sort(points.pixels), np.flatnonzero(finite))  # NaN in the PCD exactly where depth is 0
    distance = np.linalg.norm(points.xyz - organized[points.pixels], axis=1)
    assert np.median(distance) < 0.001 and np.percentile(distance, 99) < 0.001, (np.median(distance), distance.max())


def test_the_kinect_depth_tiff_gives_the_organized_pcds_points_within_a_millimetre() -> None:
    image = kinect_depth()
    pinhole, unit = kinect_pinhole()
    assert unit == 0.001  # 16UC1's millimetres
    points = depth_points(image.tobytes(), width=640, height=480, step=1280, encoding="16UC1",
                          is_bigendian=False, pinhole=pinhole)  # fmt: skip
    assert len(points.xyz) == 271575  # PROVENANCE.txt's finite points of this frame
    assert_matches_the_pcd(points)


def as_image(values: NDArray[np.generic], encoding: str, *, big_endian: bool = False, pad: int = 0) -> object:
    """A rosbags sensor_msgs/msg/Image of ``values`` (rows padded by ``pad`` bytes)."""
    ordered = values.astype(values.dtype.newbyteorder(">" if big_endian else "<"))
    rows = ordered.view(np.uint8).reshape(values.shape[0], -1)
    data = np.concatenate([rows, np.zeros((values.shape[0], pad), np.uint8)], axis=1)
    types = STORE.types
    header = types["std_msgs/msg/Header"](stamp=types["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="c")
    return types["sensor_msgs/msg/Image"](header=header, height=values.shape[0], width=values.shape[1],
                                          encoding=encoding, is_bigendian=int(big_endian), step=data.shape[1],
                                          data=data.reshape(-1))  # fmt: skip


def camera_info(pinhole: Pinhole) -> object:
    return type("Info", (), {"k": [pinhole.fx, 0, pinhole.cx, 0, pinhole.fy, pinhole.cy, 0, 0, 1]})()


def test_the_same_frame_as_32fc1_metres_big_endian_with_padded_rows() -> None:
    metres = kinect_depth().astype(np.float32) / 1000
    metres[metres == 0] = np.nan  # 32FC1 marks no return with NaN (or 0)
    pinhole, _ = kinect_pinhole()
    message = as_image(metres, "32FC1", big_endian=True, pad=12)
    assert_matches_the_pcd(image_points(message, camera_info(pinhole)))


def test_stride_keeps_every_nth_pixel_of_every_nth_row() -> None:
    image = kinect_depth()
    pinhole, _ = kinect_pinhole()
    full = image_points(as_image(image, "16UC1"), camera_info(pinhole))
    fourth = image_points(as_image(image, "16UC1"), camera_info(pinhole), stride=4)
    u, v = fourth.pixels % 640, fourth.pixels // 640
    assert (u % 4 == 0).all() and (v % 4 == 0).all()
    assert np.count_nonzero(image[::4, ::4]) == len(fourth.xyz)
    same = np.searchsorted(full.pixels, fourth.pixels)
    assert np.array_equal(full.xyz[same], fourth.xyz)


def test_a_pixel_lands_where_the_pinhole_says_in_the_optical_frame() -> None:
    """z forward, x right, y down: a pixel right of and below the centre is at +x, +y."""
    depth = np.zeros((4, 6), np.uint16)
    depth[3, 5] = 2000
    points = image_points(as_image(depth, "16UC1"), camera_info(Pinhole(100.0, 50.0, 2.0, 1.0)))
    assert points.xyz.tolist() == [[pytest.approx(0.06), pytest.approx(0.08), 2.0]] and points.pixels.tolist() == [23]


def test_an_unknown_encoding_or_a_short_image_is_named() -> None:
    pinhole = Pinhole(1.0, 1.0, 0.0, 0.0)
    with pytest.raises(CloudError, match="encoding 'rgb8' is not one of 16UC1, 32FC1"):
        depth_points(b"\0" * 12, width=2, height=2, step=6, encoding="rgb8", is_bigendian=False, pinhole=pinhole)
    with pytest.raises(CloudError, match="16UC1 2x2 with step 4 needs 8 bytes, got 7"):
        depth_points(b"\0" * 7, width=2, height=2, step=4, encoding="16UC1", is_bigendian=False, pinhole=pinhole)
    with pytest.raises(CloudError, match="encoding 'xxxxx"):
        depth_points(b"", width=0, height=0, step=0, encoding="x" * 500, is_bigendian=False, pinhole=pinhole)
    with pytest.raises(CloudError, match="not a camera matrix"):
        Pinhole.from_k([0.0] * 9)
