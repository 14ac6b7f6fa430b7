"""A simulated 2D laser scanner: beams marched through the occupancy grid (numpy, no I/O)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..fleet.occupancy import OccupancyGrid


class LaserScanner:
    """``beams`` rays over 360 degrees from the robot's centre, counter-clockwise from its heading.

    Ranges are the distance to the first occupied cell, sampled every half cell (so a 0.05 m wall cannot be
    skipped), or ``inf`` beyond ``range_max``, as sensor_msgs/LaserScan reports no return.
    """

    def __init__(self, grid: OccupancyGrid, beams: int = 360, range_min: float = 0.12, range_max: float = 8.0):
        self.grid = grid
        self.beams = beams
        self.range_min = range_min
        self.range_max = range_max
        self.angle_min = -math.pi
        self.angle_increment = 2 * math.pi / beams
        self._angles = self.angle_min + self.angle_increment * np.arange(beams)
        self._steps = np.arange(range_min, range_max, grid.resolution / 2.0)

    def scan(self, x: float, y: float, yaw: float) -> NDArray[np.float32]:
        angles = self._angles + yaw
        px = x + np.outer(np.cos(angles), self._steps)
        py = y + np.outer(np.sin(angles), self._steps)
        grid = self.grid
        cols = np.floor((px - grid.origin_x) / grid.resolution).astype(np.int64)
        rows = np.floor((py - grid.origin_y) / grid.resolution).astype(np.int64)
        inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
        hit = np.zeros_like(inside)
        hit[inside] = grid.occupied[rows[inside], cols[inside]]
        first = np.argmax(hit, axis=1)
        ranges = np.where(hit.any(axis=1), self._steps[first], np.inf)
        return ranges.astype(np.float32)
