"""A pixel of a robot's camera image as a point of the map: the lens model's ray, from the camera's pose, to what
it hits first in the map grid (a wall, an obstacle) or on the floor.

The camera sits ``CAMERA_HEIGHT`` above the robot's pose looking along its heading (the sim's mount,
relay/sim/camera.py); the ray of pixel (u, v) comes from the camera's lens model (relay/media/lens.py) at the size of
the image the operator clicked. It is marched in steps of half a grid cell up to ``MAX_RANGE``: the first occupied cell
is the hit (the face of a panel on a wall), else the floor where the ray comes down to it. Pure; tested in
tests/test_missions.py.
"""

from __future__ import annotations

import numpy as np

from ..config import Camera
from ..fleet.occupancy import OccupancyGrid
from ..media.lens import LensModel, unproject
from ..sim.camera import CAMERA_HEIGHT, camera_rotation

MAX_RANGE = 30.0


def pixel_to_map(
    camera: Camera, width: int, height: int, pose: tuple[float, float, float], u: float, v: float,
    grid: OccupancyGrid | None,
) -> tuple[float, float]:  # fmt: skip
    """Where pixel (u, v) of a ``width`` x ``height`` image from ``camera`` at ``pose`` (x, y, yaw) looks; raises
    ValueError for a pixel outside the lens's field, or a ray that hits neither the map nor the floor."""
    lens = LensModel.from_config(camera.lens, width, height)
    directions, valid = unproject(lens, np.array([[u, v]], dtype=np.float64))
    if not valid[0]:
        raise ValueError(f"pixel ({u:g}, {v:g}) is outside the field of camera {camera.name!r}")
    x0, y0, yaw = pose
    dx, dy, dz = (camera_rotation(yaw) @ directions[0]).tolist()
    step = (grid.resolution if grid is not None else 0.05) / 2
    distance = 0.0
    while distance < MAX_RANGE:
        distance += step
        x, y, z = x0 + dx * distance, y0 + dy * distance, CAMERA_HEIGHT + dz * distance
        if z <= 0.0:
            back = z / dz if dz else 0.0  # to the exact floor crossing
            return round(x - dx * back, 3), round(y - dy * back, 3)
        if grid is not None:
            if not grid.in_bounds(x, y):
                break
            if not grid.is_free(x, y):
                return round(x, 3), round(y, 3)
    raise ValueError(f"pixel ({u:g}, {v:g}) looks at nothing within {MAX_RANGE:g} m (over the walls, off the map)")
