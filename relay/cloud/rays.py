"""Free space along a cloud's rays, as a range image: which voxels the sensor has just seen through.

Tracing every ray voxel by voxel (a 3D DDA, or samples every half voxel) costs its length in voxels: a 300 000-point
Velodyne cloud at 5 cm is some 60 million steps, seconds in numpy (bench/bench_cloud_fusion.py measures it). The
question the map asks is the reverse one, and only of voxels it holds: did a ray pass through this occupied voxel and
end beyond it? So the rays are binned by direction from the sensor (bins of about ``resolution`` radians), each bin
keeping the range of its *nearest* return, and a voxel is seen through when every ray of the bin of its centre's
direction ended at least the margin beyond it. A bin no ray fell in clears nothing. A near voxel covers many bins, so
its test reads a coarser level of the image (each level's bin is the nearest return of its four finer ones: all of its
rays still end beyond), the level whose bin is the voxel's angular size or just under. The margin grows with range
(``range_margin`` of it): a ray that grazes the floor ends just beyond the floor voxels it skims, which it must not
clear. Voxels between a lidar's rings, which no ray of a scan crosses, stay until another scan's rays do.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import NDArray

#: Levels of the range image (each halves its resolution): up to 2**5 = 32 bins of the finest a side.
LEVELS: Final = 6

#: Points as three float32 columns (x, y, z), map frame.
Columns = tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32]]


class RangeImage:
    """The nearest return in each direction from ``origin``, of ``points`` (map frame)."""

    def __init__(self, origin: NDArray[np.float64], points: Columns, resolution: float) -> None:
        self.origin = origin.astype(np.float32)
        self.resolution = resolution
        unit = 2 ** (LEVELS - 1)
        self.rows = math.ceil(2 / resolution / unit) * unit  # sine of elevation: bins of `resolution` at the horizon
        self.columns = math.ceil(2 * math.pi / resolution / unit) * unit
        distance, row, column = self._polar(points)
        nearest = np.full(self.rows * self.columns, np.inf, dtype=np.float32)
        np.minimum.at(nearest, row * self.columns + column, distance)
        levels = [nearest.reshape(self.rows, self.columns)]
        for _ in range(1, LEVELS):
            f = levels[-1]
            levels.append(
                np.minimum(np.minimum(f[0::2, 0::2], f[1::2, 0::2]), np.minimum(f[0::2, 1::2], f[1::2, 1::2]))
            )
        # Every level in one array, so that each voxel reads its own level in one gather.
        self.starts = np.cumsum([0] + [level.size for level in levels[:-1]]).astype(np.intp)
        self.widths = np.array([level.shape[1] for level in levels], dtype=np.intp)
        self.pyramid = np.concatenate([level.reshape(-1) for level in levels])
        self.pyramid[np.isinf(self.pyramid)] = 0.0  # no return: nothing seen through
        self.farthest = float(distance.max()) if len(distance) else 0.0

    def _polar(self, points: Columns) -> tuple[NDArray[np.float32], NDArray[np.intp], NDArray[np.intp]]:
        """Range and bin of each point. No trigonometry (arctan2 took most of a fusion's time): the row is the sine of
        the elevation, the column the "diamond angle" (dy / (|dx| + |dy|), continued round the circle, 4 a turn),
        whose bins are 1 to 1.6 times ``resolution`` wide."""
        x, y, z = (points[axis] - self.origin[axis] for axis in range(3))
        distance = np.sqrt(x * x + y * y + z * z)
        tiny = np.float32(1e-12)
        sine = z / (distance + tiny)
        turn = y / (np.abs(x) + np.abs(y) + tiny)
        turn = np.where(x >= 0, turn, 2 - turn) + 1  # 0 .. 4
        # Both are at least 0; only the top edge (turn 4 is turn 0, sine 1) needs bounding. np.clip and % took a third
        # of a fusion's time.
        column = np.minimum((turn * np.float32(self.columns / 4)).astype(np.intp), self.columns - 1)
        row = np.minimum(((sine + 1) * np.float32(self.rows / 2)).astype(np.intp), self.rows - 1)
        return distance, row, column

    def seen_through(self, centres: Columns, voxel: float, margin: float, range_margin: float) -> NDArray[np.bool_]:
        """Which voxel ``centres`` (map frame) every ray of their direction passed at least the margin beyond."""
        distance, row, column = self._polar(centres)
        # Level n where the voxel spans 2**n to 2**(n+1) finest bins: found among the levels' distances.
        limits = voxel / (self.resolution * 2.0 ** np.arange(LEVELS - 1, 0, -1))
        level = np.zeros(len(distance), dtype=np.intp)
        for limit in limits.astype(np.float32).tolist():  # five comparisons: quicker than a search per voxel
            level += distance <= limit
        beyond = self._read(level, row, column)
        seen: NDArray[np.bool_] = distance + margin + range_margin * distance < beyond
        return seen

    def _read(self, level: NDArray[np.intp], row: NDArray[np.intp], column: NDArray[np.intp]) -> NDArray[np.float32]:
        found: NDArray[np.float32] = self.pyramid[
            self.starts[level] + (row >> level) * self.widths[level] + (column >> level)
        ]
        return found
