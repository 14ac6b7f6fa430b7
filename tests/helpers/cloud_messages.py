"""The shared real clouds (tests/helpers/clouds.py) as the ROS messages a robot sends: PointCloud2 (the Velodyne
scans; the Kinect's organized PCD with its colours), 16UC1 depth Image with its CameraInfo (the Kinect's TIFF and
intrinsics), and the poses and static transforms that place them; rosbags' objects, CDR bytes, a rosbag2; and the
offline reference of their occupied voxels (numpy: every point's voxel, in float64)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from rosbags.typesys import Stores, get_typestore

from relay.cloud.pcd import read_pcd
from relay.cloud.pointcloud2 import encode_pointcloud2, unpack_rgb
from tests.helpers.clouds import (
    KINECT,
    KINECT_FRAMES,
    VELODYNE,
    VELODYNE_SOURCE,
    VELODYNE_TARGET,
    pointcloud_data,
    velodyne_relative,
)

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types
#: The Kinect's optical frame (z forward, x right, y down) on a robot looking along +x, 0.5 m above its base.
OPTICAL = np.array([[0, 0, 1, 0.1], [-1, 0, 0, 0], [0, -1, 0, 0.5], [0, 0, 0, 1]], dtype=np.float64)
#: fx = fy = 525, cx = 320, cy = 240 (PROVENANCE.txt; the frames' pclzf/*.xml).
KINECT_K = (525.0, 0.0, 320.0, 0.0, 525.0, 240.0, 0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Timed:
    """A message, its topic and type, and the time it is sent or recorded at (s)."""

    stamp: float
    topic: str
    type: str
    message: Any

    def cdr(self) -> bytes:
        return bytes(STORE.serialize_cdr(self.message, self.type))


def header(stamp: float, frame: str) -> Any:
    sec = math.floor(stamp)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((stamp - sec) * 1e9)), frame_id=frame
    )


def quaternion(rotation: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a 3x3 rotation matrix (Shepperd's method, the largest pivot)."""
    m = rotation
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        return ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    i = int(np.argmax(np.diag(m)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2.0 * math.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s
    q[j] = (m[j, i] + m[i, j]) / s
    q[k] = (m[k, i] + m[i, k]) / s
    q[3] = (m[k, j] - m[j, k]) / s
    return (q[0], q[1], q[2], q[3])


def pointcloud2(fields: Any, stamp: float, frame: str) -> Any:
    """relay.cloud.pointcloud2.PointCloud2Fields as rosbags' sensor_msgs/msg/PointCloud2."""
    return T["sensor_msgs/msg/PointCloud2"](
        header=header(stamp, frame), height=fields.height, width=fields.width,
        fields=[T["sensor_msgs/msg/PointField"](name=f.name, offset=f.offset, datatype=f.datatype, count=f.count)
                for f in fields.fields],
        is_bigendian=fields.is_bigendian, point_step=fields.point_step, row_step=fields.row_step,
        data=np.frombuffer(fields.data, dtype=np.uint8), is_dense=fields.is_dense,
    )  # fmt: skip


def odometry(stamp: float, pose: NDArray[np.float64], child: str = "base_link") -> Any:
    x, y, z, w = quaternion(pose[:3, :3])
    p = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(pose[0, 3]), y=float(pose[1, 3]), z=float(pose[2, 3])),
        orientation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w),
    )
    return T["nav_msgs/msg/Odometry"](
        header=header(stamp, "map"), child_frame_id=child,
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](linear=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                                               angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)),
            covariance=np.zeros(36)),
    )  # fmt: skip


def tf_static(stamp: float, parent: str, child: str, pose: NDArray[np.float64]) -> Any:
    x, y, z, w = quaternion(pose[:3, :3])
    transform = T["geometry_msgs/msg/TransformStamped"](
        header=header(stamp, parent), child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=float(pose[0, 3]), y=float(pose[1, 3]), z=float(pose[2, 3])),
            rotation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)),
    )  # fmt: skip
    return T["tf2_msgs/msg/TFMessage"](transforms=[transform])


def depth_image(depth: NDArray[np.uint16], stamp: float, frame: str, encoding: str = "16UC1") -> Any:
    return T["sensor_msgs/msg/Image"](
        header=header(stamp, frame), height=depth.shape[0], width=depth.shape[1], encoding=encoding,
        is_bigendian=0, step=depth.shape[1] * 2, data=depth.astype("<u2").view(np.uint8).reshape(-1),
    )  # fmt: skip


def camera_info(stamp: float, frame: str, width: int = 640, height: int = 480) -> Any:
    return T["sensor_msgs/msg/CameraInfo"](
        header=header(stamp, frame), height=height, width=width, distortion_model="plumb_bob",
        d=np.zeros(5), k=np.array(KINECT_K), r=np.eye(3).reshape(-1),
        p=np.array([525.0, 0, 320.0, 0, 0, 525.0, 240.0, 0, 0, 0, 1.0, 0]), binning_x=0, binning_y=0,
        roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
    )  # fmt: skip


# -- the shared frames ------------------------------------------------------------------------------


def velodyne_scans() -> list[tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float64]]]:
    """(points, intensities, the scan's pose in the map): the target scan at the origin, the source where
    relative.txt puts it."""
    folder = pointcloud_data(VELODYNE)
    out = []
    for name, pose in ((VELODYNE_TARGET, np.eye(4)), (VELODYNE_SOURCE, velodyne_relative())):
        cloud = read_pcd(folder / name).cloud()
        assert cloud.intensity is not None
        out.append((cloud.xyz, cloud.intensity, pose))
    return out


def kinect_organized(frame: str) -> tuple[NDArray[np.float32], NDArray[np.uint8]]:
    """The organized PCD's 640x480 points (NaN where no return) and colours."""
    pcd = read_pcd(pointcloud_data(KINECT) / "pcd" / f"frame_{frame}.pcd")
    return pcd.xyz(), unpack_rgb(pcd.points["rgba"].view(np.uint32))


def kinect_depth(frame: str) -> NDArray[np.uint16]:
    path = pointcloud_data(KINECT) / "tiff" / f"frame_{frame}_depth.tiff"
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert image is not None and image.dtype == np.uint16 and image.shape == (480, 640)
    return np.asarray(image, dtype=np.uint16)


def kinect_pointcloud2(frame: str, stamp: float, frame_id: str = "camera_depth_optical_frame") -> Any:
    xyz, rgb = kinect_organized(frame)
    return pointcloud2(encode_pointcloud2(xyz, rgb, width=640), stamp, frame_id)


def placed(points: NDArray[np.floating[Any]], pose: NDArray[np.float64]) -> NDArray[np.float64]:
    return points.astype(np.float64) @ pose[:3, :3].T + pose[:3, 3]


def reference_voxels(
    clouds: Iterable[tuple[NDArray[np.floating[Any]], NDArray[np.float64]]], voxel: float
) -> set[tuple[int, int, int]]:
    """Every finite point's voxel, each cloud placed by its pose in float64, nothing cleared."""
    points = np.concatenate([placed(xyz[np.isfinite(xyz).all(axis=1)], pose) for xyz, pose in clouds])
    return as_set(np.floor(points / voxel).astype(np.int64))


def as_set(indices: NDArray[np.int64]) -> set[tuple[int, int, int]]:
    return {(i, j, k) for i, j, k in np.unique(indices, axis=0).tolist()}


def write_bag(path: Path, records: Iterable[Timed]) -> Path:
    """A rosbag2 (sqlite3) of ``records``, each logged at its ``stamp``."""
    from rosbags.rosbag2 import Writer

    ordered = sorted(records, key=lambda r: r.stamp)
    with Writer(path, version=8) as writer:
        connections: dict[str, Any] = {}
        for record in ordered:
            if record.topic not in connections:
                connections[record.topic] = writer.add_connection(record.topic, record.type, typestore=STORE)
            writer.write(connections[record.topic], round(record.stamp * 1e9), record.cdr())
    return path


__all__ = ["KINECT_FRAMES", "STORE", "T", "Timed"]
