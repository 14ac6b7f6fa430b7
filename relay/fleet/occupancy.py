"""Boolean occupancy grids in the map frame (REP 103: x east, y north, metres).

One grid type serves the simulator (bumper, rasterised floor plan), goal
validation and, later, map -> glTF export, so its conventions are fixed here:

* ``occupied[row, col]`` with ``row`` along +y and ``col`` along +x.
  Row 0 is the *lowest* y, i.e. ROS ``nav_msgs/OccupancyGrid`` order, not
  image order (image row 0 is the top).
* ``(origin_x, origin_y)`` is the lower-left corner of cell (0, 0); cell
  ``(r, c)`` covers ``[origin_x + c*res, origin_x + (c+1)*res)`` along x and
  likewise along y.
* The grid is boolean: ``True`` means "the robot may not be here". Unknown
  cells of a loaded map count as occupied (see :func:`from_map_yaml`).

Only :func:`from_map_yaml` touches the file system.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import NDArray

__all__ = ["OccupancyGrid", "from_map_yaml"]

# Slack for float comparisons of coordinates that are nominally on a cell
# boundary (e.g. 0.15 / 0.05 == 2.9999999999999996), so that radii and
# extents written as round decimals behave as the author meant.
_EPS = 1e-9


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """An axis-aligned boolean occupancy grid.

    Contract:
        * ``resolution > 0`` and finite; origins finite.
        * ``occupied`` is 2-D ``(height, width)``, both at least 1; it is
          copied to a read-only ``bool`` array on construction so that a grid
          can never change under a cached consumer (e.g. a planner).
        * Equality and hashing are by identity (``eq=False``): element-wise
          array comparison has no single truth value, and identity is what
          caches keyed on a grid need.
    """

    origin_x: float
    origin_y: float
    resolution: float
    occupied: NDArray[np.bool_]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise ValueError(f"resolution must be a positive finite number, got {self.resolution!r}")
        if not (math.isfinite(self.origin_x) and math.isfinite(self.origin_y)):
            raise ValueError(f"origin must be finite, got ({self.origin_x!r}, {self.origin_y!r})")
        occ = np.array(self.occupied, dtype=np.bool_, copy=True)
        if occ.ndim != 2 or occ.shape[0] < 1 or occ.shape[1] < 1:
            raise ValueError(f"occupied must be a non-empty 2-D array, got shape {occ.shape}")
        occ.flags.writeable = False
        # frozen dataclass: bypass __setattr__ once to install the private copy.
        object.__setattr__(self, "occupied", occ)
        object.__setattr__(self, "origin_x", float(self.origin_x))
        object.__setattr__(self, "origin_y", float(self.origin_y))
        object.__setattr__(self, "resolution", float(self.resolution))

    @property
    def width(self) -> int:
        """Number of columns (cells along x)."""
        return int(self.occupied.shape[1])

    @property
    def height(self) -> int:
        """Number of rows (cells along y)."""
        return int(self.occupied.shape[0])

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(min_x, min_y, max_x, max_y)`` of the covered area in metres."""
        return (
            self.origin_x,
            self.origin_y,
            self.origin_x + self.width * self.resolution,
            self.origin_y + self.height * self.resolution,
        )

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """Return ``(row, col)`` of the cell containing ``(x, y)``.

        The result may be out of range (negative or >= size); use
        :meth:`in_bounds` to check. Raises ``ValueError`` for non-finite input.
        """
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"point ({x!r}, {y!r}) is not finite")
        col = math.floor((x - self.origin_x) / self.resolution)
        row = math.floor((y - self.origin_y) / self.resolution)
        return row, col

    def cell_to_world(self, row: int, col: int) -> tuple[float, float]:
        """Return the map coordinates of the centre of cell ``(row, col)``.

        Works for out-of-range indices too (the grid is conceptually infinite).
        """
        return (
            self.origin_x + (col + 0.5) * self.resolution,
            self.origin_y + (row + 0.5) * self.resolution,
        )

    def in_bounds(self, x: float, y: float) -> bool:
        """True when ``(x, y)`` lies inside the grid; False for NaN/inf."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return False
        row, col = self.world_to_cell(x, y)
        return 0 <= row < self.height and 0 <= col < self.width

    def is_free(self, x: float, y: float) -> bool:
        """True when ``(x, y)`` is inside the grid and its cell is not occupied.

        Outside the grid counts as not free: nothing is known there, and a
        robot must not be sent off the map.
        """
        if not self.in_bounds(x, y):
            return False
        row, col = self.world_to_cell(x, y)
        return not bool(self.occupied[row, col])

    def clearance(self, x: float, y: float, limit: float) -> float:
        """Distance from ``(x, y)`` to the nearest occupied cell *centre*, capped at ``limit``.

        Only the cells within ``limit`` are examined, so this is cheap
        (O((limit/resolution)^2)) and needs no inflated grid. Returns
        ``limit`` when nothing is that close and ``0.0`` for a point outside
        the grid (off the map counts as touching an obstacle). The distance
        convention matches :meth:`inflate`: ``clearance(x, y, r) <= r`` iff
        the cell at ``(x, y)`` is occupied in ``inflate(r)`` when ``(x, y)``
        is a cell centre.
        """
        if not self.in_bounds(x, y):
            return 0.0
        if limit <= 0.0:
            return max(limit, 0.0)
        res = self.resolution
        k = math.ceil(limit / res) + 1
        row, col = self.world_to_cell(x, y)
        r0, r1 = max(row - k, 0), min(row + k + 1, self.height)
        c0, c1 = max(col - k, 0), min(col + k + 1, self.width)
        rr, cc = np.nonzero(self.occupied[r0:r1, c0:c1])
        if rr.size == 0:
            return limit
        dx = self.origin_x + (cc + c0 + 0.5) * res - x
        dy = self.origin_y + (rr + r0 + 0.5) * res - y
        return min(math.sqrt(float(np.min(dx * dx + dy * dy))), limit)

    def with_discs(self, discs: Iterable[tuple[float, float, float]]) -> OccupancyGrid:
        """Return a copy with every cell whose centre lies in one of ``discs`` (x, y, radius, metres) occupied.

        The sim plans around the other robots this way: their footprints become obstacles for one plan (about
        1 ms for the demo's 360 x 200 grid and three robots). Discs off the grid change nothing.
        """
        discs = list(discs)
        if not discs:
            return self
        occ = self.occupied.copy()
        xs = self.origin_x + (np.arange(self.width) + 0.5) * self.resolution
        ys = self.origin_y + (np.arange(self.height) + 0.5) * self.resolution
        for x, y, radius in discs:
            occ |= ((xs[np.newaxis, :] - x) ** 2 + (ys[:, np.newaxis] - y) ** 2) <= radius * radius
        return OccupancyGrid(self.origin_x, self.origin_y, self.resolution, occ)

    def inflate(self, radius: float) -> OccupancyGrid:
        """Return a grid whose occupied cells are dilated by a disk of ``radius`` metres.

        A cell becomes occupied when the centre of some occupied cell lies
        within ``radius`` of its own centre (centre-to-centre distance, so the
        true clearance to the obstacle's edge can be up to half a cell less).
        ``radius <= 0`` (or less than one cell) returns ``self`` unchanged.
        The area outside the grid is not treated as occupied.

        Cost: O(r) whole-array passes for a radius of ``r`` cells rather than
        the O(r^2) of OR-ing every disk offset, because the disk is built as
        a union of horizontal runs whose half-widths are shared between rows.
        """
        r_cells = radius / self.resolution
        r = math.floor(r_cells + _EPS)
        if radius <= 0.0 or r < 1:
            return self
        occ = self.occupied
        rows, cols = occ.shape
        padded = np.zeros((rows + 2 * r, cols + 2 * r), dtype=np.bool_)
        padded[r : r + rows, r : r + cols] = occ
        # horiz[w][i, j] = any(padded[i, j-w : j+w+1]); built incrementally so
        # each half-width costs two shifted ORs.
        horiz: list[NDArray[np.bool_]] = [padded]
        acc = padded
        for w in range(1, r + 1):
            acc = acc.copy()
            acc[:, w:] |= padded[:, :-w]
            acc[:, :-w] |= padded[:, w:]
            horiz.append(acc)
        out = np.zeros((rows, cols), dtype=np.bool_)
        for dy in range(-r, r + 1):
            half = math.floor(math.sqrt(max(r_cells * r_cells - dy * dy, 0.0)) + _EPS)
            out |= horiz[min(half, r)][r + dy : r + dy + rows, r : r + cols]
        return OccupancyGrid(self.origin_x, self.origin_y, self.resolution, out)

    def segment_free(self, x0: float, y0: float, x1: float, y1: float) -> bool:
        """True when every cell along the segment ``(x0, y0) -> (x1, y1)`` is free.

        The segment is sampled every ``resolution / 2`` (endpoints included),
        so a segment may clip the corner of an occupied cell by a sliver;
        callers that need a hard guarantee should check against an inflated
        grid. Any sample outside the grid makes the segment not free.
        """
        if not all(math.isfinite(v) for v in (x0, y0, x1, y1)):
            return False
        dx = x1 - x0
        dy = y1 - y0
        n = max(1, math.ceil(math.hypot(dx, dy) / (0.5 * self.resolution)))
        t = np.linspace(0.0, 1.0, n + 1)
        cols = np.floor((x0 + t * dx - self.origin_x) / self.resolution).astype(np.intp)
        rows = np.floor((y0 + t * dy - self.origin_y) / self.resolution).astype(np.intp)
        if cols.min() < 0 or rows.min() < 0 or cols.max() >= self.width or rows.max() >= self.height:
            return False
        return not bool(self.occupied[rows, cols].any())


# ---------------------------------------------------------------------------
# map_server loading

_PGM_WHITESPACE = b" \t\n\r\v\f"
_MODES = ("trinary", "scale", "raw")


def read_pgm(path: Path) -> tuple[NDArray[np.int64], int]:
    """Parse a binary (P5) or plain (P2) PGM; return ``(pixels, maxval)``.

    ``pixels`` has shape ``(height, width)`` in *image* order (row 0 = top).
    Raises ``ValueError`` naming ``path`` for anything unreadable or malformed.
    """
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read map image: {exc.strerror or exc}") from exc
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise ValueError(
            f"{path}: not a PGM image (expected magic P5 or P2, got {magic!r}); only PGM map images are supported"
        )

    # Header: three integers (width, height, maxval) separated by whitespace,
    # with '#' comments allowed between them (map_saver writes one).
    pos = 2
    header: list[int] = []
    while len(header) < 3:
        while pos < len(data) and data[pos] in _PGM_WHITESPACE:
            pos += 1
        if pos >= len(data):
            raise ValueError(f"{path}: truncated PGM header")
        if data[pos] == ord("#"):
            end = data.find(b"\n", pos)
            pos = len(data) if end < 0 else end + 1
            continue
        start = pos
        while pos < len(data) and data[pos] not in _PGM_WHITESPACE and data[pos] != ord("#"):
            pos += 1
        token = data[start:pos]
        if not token.isdigit():
            raise ValueError(f"{path}: bad PGM header field {token!r}")
        header.append(int(token))
    width, height, maxval = header
    if width < 1 or height < 1:
        raise ValueError(f"{path}: PGM size {width}x{height} is empty")
    if not 1 <= maxval <= 65535:
        raise ValueError(f"{path}: PGM maxval {maxval} out of range 1..65535")
    count = width * height

    if magic == b"P5":
        # Exactly one whitespace byte separates maxval from the raster; the
        # raster may legitimately start with a byte that looks like whitespace.
        if pos >= len(data):
            raise ValueError(f"{path}: PGM has no pixel data")
        pos += 1
        dtype = np.dtype(np.uint8) if maxval < 256 else np.dtype(">u2")
        needed = count * dtype.itemsize
        if len(data) - pos < needed:
            raise ValueError(f"{path}: truncated PGM pixel data ({len(data) - pos} bytes, expected {needed})")
        pixels = np.frombuffer(data, dtype=dtype, count=count, offset=pos).astype(np.int64)
    else:
        body = data[pos:]
        if b"#" in body:
            # Not allowed by the spec in the raster, but tolerated: some
            # hand-written maps carry comments anywhere.
            body = b"\n".join(line.split(b"#", 1)[0] for line in body.split(b"\n"))
        tokens = body.split()
        if len(tokens) < count:
            raise ValueError(f"{path}: truncated PGM pixel data ({len(tokens)} values, expected {count})")
        try:
            pixels = np.array([int(t) for t in tokens[:count]], dtype=np.int64)
        except ValueError as exc:
            raise ValueError(f"{path}: non-numeric PGM pixel value") from exc
    if pixels.size and (pixels.min() < 0 or pixels.max() > maxval):
        raise ValueError(f"{path}: PGM pixel value outside 0..{maxval}")
    return pixels.reshape(height, width), maxval


def _number(meta: dict[str, Any], key: str, where: Path) -> float:
    """Fetch a required real-number field of a map yaml."""
    if key not in meta:
        raise ValueError(f"{where}: missing required field '{key}'")
    value = meta[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{where}: field '{key}' must be a finite number, got {value!r}")
    return float(value)


def read_yaml(path: Path, what: str) -> Any:
    """The YAML document in ``path``; ValueError naming the file (and ``what`` it should be) otherwise."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ValueError(f"{path}: cannot read {what}: {reason}") from exc
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: invalid YAML: {exc}") from exc


def from_map_yaml(path: str | os.PathLike[str]) -> OccupancyGrid:
    """Load a ROS ``map_server`` map (``map.yaml`` + PGM image) as an :class:`OccupancyGrid`.

    Honoured fields: ``image`` (relative to the yaml's directory unless
    absolute), ``resolution``, ``origin`` ``[x, y, yaw]``, ``negate``,
    ``occupied_thresh``, ``free_thresh`` and ``mode`` (default ``trinary``).
    Pixel values are turned into an occupancy probability the way map_server
    does (``p = (maxval - v) / maxval``, or ``v / maxval`` when negated; in
    ``raw`` mode the value itself is a 0..100 percentage and negate is
    ignored, anything above 100 meaning unknown).

    Boolean mapping (deliberately conservative, because the grid is used for
    planning and goal validation): a cell is *free* only when
    ``p < free_thresh``; occupied cells (``p > occupied_thresh``), unknown
    cells (trinary band in between, or raw > 100) and ``scale``-mode
    intermediate costs all count as **occupied**, so nothing is ever planned
    through unexplored space.

    The image's top row becomes the highest row (ROS order). Rotated origins
    (yaw != 0) are rejected because the grid is axis-aligned.

    Raises:
        ValueError: naming the offending file, when the yaml or image is
            missing, unreadable or malformed, or a field is invalid.
    """
    yaml_path = Path(path)
    meta = read_yaml(yaml_path, "map yaml")
    # A non-mapping document is bad *content*, hence ValueError like every
    # other defect of the file.
    meta = meta if isinstance(meta, dict) else None
    if meta is None:
        raise ValueError(f"{yaml_path}: expected a mapping of map fields")

    image = meta.get("image")
    if not isinstance(image, str) or not image:
        raise ValueError(f"{yaml_path}: missing or invalid field 'image'")
    resolution = _number(meta, "resolution", yaml_path)
    if resolution <= 0.0:
        raise ValueError(f"{yaml_path}: resolution must be > 0, got {resolution}")
    origin = meta.get("origin")
    if (
        not isinstance(origin, list)
        or len(origin) not in (2, 3)
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in origin)
        or not all(math.isfinite(v) for v in origin)
    ):
        raise ValueError(f"{yaml_path}: field 'origin' must be [x, y, yaw] numbers, got {origin!r}")
    if len(origin) == 3 and abs(float(origin[2])) > _EPS:
        raise ValueError(f"{yaml_path}: rotated map origin (yaw={origin[2]}) is not supported")
    if "negate" not in meta or not isinstance(meta["negate"], (bool, int)) or meta["negate"] not in (0, 1):
        raise ValueError(f"{yaml_path}: field 'negate' must be 0 or 1, got {meta.get('negate')!r}")
    negate = bool(meta["negate"])
    occupied_thresh = _number(meta, "occupied_thresh", yaml_path)
    free_thresh = _number(meta, "free_thresh", yaml_path)
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise ValueError(
            f"{yaml_path}: need 0 <= free_thresh <= occupied_thresh <= 1, "
            f"got free_thresh={free_thresh}, occupied_thresh={occupied_thresh}"
        )
    mode = meta.get("mode", "trinary")
    if mode not in _MODES:
        raise ValueError(f"{yaml_path}: field 'mode' must be one of {_MODES}, got {mode!r}")

    image_path = Path(image)
    if not image_path.is_absolute():
        image_path = yaml_path.parent / image_path
    pixels, maxval = read_pgm(image_path)

    if mode == "raw":
        # map_server rescales to 8 bits before reading the value as percent.
        percent = np.rint(pixels * (255.0 / maxval))
        free = percent < free_thresh * 100.0
    else:
        shade = pixels / float(maxval)
        p = shade if negate else 1.0 - shade
        free = p < free_thresh
    occupied = ~free[::-1, :]
    return OccupancyGrid(float(origin[0]), float(origin[1]), resolution, occupied)
