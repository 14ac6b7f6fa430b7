"""The simulated depth camera: the facility's distance along each pixel's ray, as a point cloud (no I/O).

Issue #33's demo grows a 3D map as the robots drive, so each simulated robot carries a depth camera: a pinhole
(:data:`FIELD_OF_VIEW` across, 4:3) at the colour camera's height, tilted down by :data:`PITCH` so that it sees the
floor before it and the walls to above a person's height. Its rays are cast against the same facility mesh the
colour camera renders (:class:`relay.sim.camera.SimCamera`, Embree), so its points lie on the twin's surfaces: no
noise is made up. A ray that hits nothing, or hits beyond :data:`RANGE_MAX` (an RGB-D camera's useful range), gives
no point, as a real depth image has no value there.

Points come in the camera's optical frame (+z forward, +x right, +y down), with the camera's pose in the map, which
is what :meth:`relay.cloud.voxels.VoxelMap.integrate` takes (the pose's translation is where rays start, for clearing).
Blocking: a 160 x 120 scan takes 10 ms with Embree on the project's 2-core machine (mean of 20, the other core busy);
the backend runs it in a worker thread.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from ..media.lens import LensModel
from .camera import CAMERA_HEIGHT, SimCamera, camera_rotation

#: Horizontal field of view (degrees) of a Kinect- or RealSense-class depth camera.
FIELD_OF_VIEW: Final = 86.0
#: Image size with Embree, and with the pure-Python intersector (some 4000 rays a second: 48 x 36 in under half a s).
SIZE: Final = (160, 120)
FALLBACK_SIZE: Final = (48, 36)
#: Tilt down (rad, REP 103: positive pitches down): 15 degrees shows the floor from 1.1 m out and walls to 2.5 m high
#: at 4 m.
PITCH: Final = math.radians(15.0)
#: Farthest return kept (m): structured-light and stereo depth are noisy beyond.
RANGE_MAX: Final = 8.0


@dataclass(frozen=True, slots=True)
class DepthScan:
    """What a depth camera saw: ``points`` (N, 3) float32 in its optical frame, ``pose`` (4x4) the optical frame in
    the map frame."""

    points: NDArray[np.float32]
    pose: NDArray[np.float64]


class SimDepthCamera:
    """Depth from any robot pose, by ray casting ``camera``'s facility mesh. Immutable; safe across threads."""

    def __init__(self, camera: SimCamera, height: float = CAMERA_HEIGHT, pitch: float = PITCH) -> None:
        self.camera = camera
        self.height, self.pitch = height, pitch
        width, rows = SIZE if camera.engine == "embree" else FALLBACK_SIZE
        self.lens = LensModel.create("pinhole", width, rows, FIELD_OF_VIEW)
        # Each face's plane (unit normal, offset n.v0): a hit's distance follows from the face it hit.
        normals = camera.normals.astype(np.float64)
        self._planes = np.concatenate([normals, np.einsum("ij,ij->i", normals, camera.mesh.triangles[:, 0])[:, None]],
                                      axis=1)  # fmt: skip

    def scan(self, x: float, y: float, yaw: float) -> DepthScan:
        """The points seen from a robot at ``(x, y, yaw)`` (map frame, metres, radians)."""
        grid = self.camera.rays(self.lens)
        faces = self.camera.trace(x, y, yaw, self.lens, self.height, self.pitch).reshape(-1)[grid.index]
        rotation = camera_rotation(yaw, self.pitch)
        origin = np.array([x, y, self.height])
        hit = faces >= 0
        optical = grid.directions[hit].astype(np.float64)
        plane = self._planes[faces[hit]]
        # t = (n.v0 - n.o) / (n.d), with d the ray in the map frame.
        along = np.einsum("ij,ij->i", plane[:, :3], optical @ rotation.T)
        distance = (plane[:, 3] - plane[:, :3] @ origin) / np.where(along == 0.0, 1e-12, along)
        keep = (distance > 0.0) & (distance <= RANGE_MAX)
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = rotation, origin
        points = (optical[keep] * distance[keep, None]).astype(np.float32)
        return DepthScan(points, pose)
