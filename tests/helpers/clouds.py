"""The shared real clouds (../shared/data/pointcloud; each folder's PROVENANCE.txt says what they are)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from tests.conftest import SHARED_DATA

KINECT = "pcl_grabber_sequences_kinect"
VELODYNE = "fast_gicp_velodyne_pair"
#: The Kinect frames' timestamps, in each of their file names (0.25 s apart, the camera still).
KINECT_FRAMES = ("20121214T142255.814212", "20121214T142256.068683", "20121214T142256.332395")
KINECT_FRAME = KINECT_FRAMES[0]
#: The Velodyne pair: 251371071 is fast_gicp's *source*, 251370668 its *target*; relative.txt maps source to target.
VELODYNE_TARGET, VELODYNE_SOURCE = "251370668.pcd", "251371071.pcd"


def pointcloud_data(folder: str) -> Path:
    """A folder of ../shared/data/pointcloud; skips the test, naming it, when it is absent."""
    path = SHARED_DATA / "pointcloud" / folder
    if not path.is_dir():
        pytest.skip(f"needs ../shared/data/pointcloud/{folder} (absent: {path})")
    return path


def velodyne_relative() -> NDArray[np.float64]:
    """relative.txt's 4x4 transform: the source scan's points into the target scan's frame."""
    return np.loadtxt(pointcloud_data(VELODYNE) / "relative.txt").reshape(4, 4)
