"""Depth images to points in the camera's optical frame (REP 103's ``_optical``: z forward, x right, y down).

A sensor_msgs/Image of encoding ``16UC1`` (millimetres, 0 = no return) or ``32FC1`` (metres, NaN or 0 = no return),
read with its row ``step`` and byte order, and the pinhole of its sensor_msgs/CameraInfo (``K``: fx, fy, cx, cy, as
depth_image_proc's point_cloud_xyz uses them): pixel (u, v) at depth z is ((u - cx) z / fx, (v - cy) z / fy, z).
``stride`` keeps every n-th pixel of every n-th row. Pure numpy; an unknown encoding or bytes that do not fill the
image are a :class:`~relay.cloud.errors.CloudError` naming them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from .errors import CloudError, shown

#: Encoding -> (numpy type, metres per unit): REP 118's depth image units.
ENCODINGS: Final[dict[str, tuple[str, float]]] = {"16UC1": ("u2", 0.001), "32FC1": ("f4", 1.0)}


@dataclass(frozen=True, slots=True)
class Pinhole:
    """A camera's focal lengths and principal point, in pixels."""

    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_k(cls, k: Sequence[float]) -> Pinhole:
        """From CameraInfo's ``K`` (``k`` in ROS 2): the 3x3 matrix, row-major."""
        if len(k) != 9 or not (k[0] > 0 and k[4] > 0):
            raise CloudError(f"CameraInfo K is not a camera matrix: {list(k)[:9]}")
        return cls(float(k[0]), float(k[4]), float(k[2]), float(k[5]))


@dataclass(frozen=True, slots=True)
class DepthPoints:
    """``xyz`` (N, 3) float32 in the optical frame, and the flat pixel index (v * width + u) each came from, so a
    registered colour image can colour them."""

    xyz: NDArray[np.float32]
    pixels: NDArray[np.int64]


def depth_points(
    data: bytes | memoryview | NDArray[np.uint8],
    *,
    width: int,
    height: int,
    step: int,
    encoding: str,
    is_bigendian: bool,
    pinhole: Pinhole,
    stride: int = 1,
) -> DepthPoints:
    """The points of a depth image's valid pixels (finite and above zero), every ``stride``-th in each direction."""
    if encoding not in ENCODINGS:
        raise CloudError(f"depth image encoding {shown(encoding)} is not one of {', '.join(ENCODINGS)}")
    if stride < 1:
        raise CloudError(f"depth stride {stride} is below 1")
    kind, scale = ENCODINGS[encoding]
    item = np.dtype(kind).itemsize
    raw = np.frombuffer(data, dtype=np.uint8) if isinstance(data, bytes) else np.asarray(data).view(np.uint8).ravel()
    if step < width * item or len(raw) < step * height:
        raise CloudError(
            f"depth image {encoding} {width}x{height} with step {step} needs {step * height} bytes, got {len(raw)}"
        )
    rows = raw[: step * height].reshape(height, step)[::stride, : width * item]
    values = np.ascontiguousarray(rows).view((">" if is_bigendian else "<") + kind)[:, ::stride]
    z = values.astype(np.float32) * np.float32(scale)
    v_index, u_index = np.nonzero(np.isfinite(z) & (z > 0))
    depth = z[v_index, u_index]
    u = (u_index * stride).astype(np.float32)
    v = (v_index * stride).astype(np.float32)
    xyz = np.empty((len(depth), 3), dtype=np.float32)
    xyz[:, 0] = (u - np.float32(pinhole.cx)) * depth / np.float32(pinhole.fx)
    xyz[:, 1] = (v - np.float32(pinhole.cy)) * depth / np.float32(pinhole.fy)
    xyz[:, 2] = depth
    pixels = (v_index * stride).astype(np.int64) * width + u_index * stride
    return DepthPoints(xyz, pixels)


def image_points(image: Any, camera_info: Any, stride: int = 1) -> DepthPoints:
    """:func:`depth_points` of a sensor_msgs/Image and its CameraInfo (rosbags' or rclpy's)."""
    return depth_points(
        image.data,
        width=int(image.width),
        height=int(image.height),
        step=int(image.step),
        encoding=str(image.encoding),
        is_bigendian=bool(image.is_bigendian),
        pinhole=Pinhole.from_k(camera_info.k),
        stride=stride,
    )
