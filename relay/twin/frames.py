"""The one place where ROS coordinates meet glTF coordinates.

ROS (REP 103) is right-handed Z-up: x forward/east, y left/north, z up. glTF 2.0 is right-handed Y-up with
+Z towards the viewer. The rotation between them is -90 degrees about x:

    gltf = (x_ros, z_ros, -y_ros)        ros = (x_gltf, -z_gltf, y_gltf)

A yaw about ROS +z is a rotation about glTF +y by the same angle. The client applies the same mapping in
``xr_client/src/frames.js``; tests pin both with the same points.

``scene.map_to_scene`` in robots.yaml places the map frame inside the scene in ROS conventions: a map point
``p`` is at ``Rz(yaw) p + (x, y, z)`` in the scene's ROS frame, then converted to glTF as above.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

#: 4x4 homogeneous matrix taking ROS (Z-up) coordinates to glTF (Y-up) coordinates.
ROS_TO_GLTF: NDArray[np.float64] = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
#: Its inverse (and transpose): glTF to ROS.
GLTF_TO_ROS: NDArray[np.float64] = ROS_TO_GLTF.T.copy()


def ros_to_gltf(x: float, y: float, z: float) -> tuple[float, float, float]:
    return x, z, -y


def gltf_to_ros(x: float, y: float, z: float) -> tuple[float, float, float]:
    return x, -z, y


def map_to_scene_matrix(x: float, y: float, z: float, yaw: float) -> NDArray[np.float64]:
    """4x4 matrix taking map-frame points (ROS) to scene points (ROS), from robots.yaml's map_to_scene."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]])
