"""Map twins: a glTF scene extruded from an occupancy grid (a map.yaml, or a live ``/map``).

The twin is a ``floor`` plane over the map's whole extent at height 0 plus a ``walls`` mesh: every wall cell
becomes a column ``wall_height`` tall. The map frame is the scene frame (``map_to_scene`` identity) and the
output is glTF Y-up through :mod:`relay.twin.frames`, like every twin of the project.

Merging, so that a 1.7 megacell map stays a few draw calls and a few megabytes:

* the tops of the walls are rectangles: runs of wall cells along each row, then runs with the same column
  span in consecutive rows joined into one rectangle (greedy, vectorised with numpy);
* only the *exposed* side faces are emitted: the boundaries between a wall cell and a non-wall cell (or the
  map's edge), joined along each boundary line into one quad per run. Faces between two wall cells, and the
  bottoms (on the floor), are never written.

**Unknown cells are not walls**: an unexplored area is shown as floor (optionally darkened by the
``unknown`` overlay, a flat mesh 3 mm above the floor), never as a block, because most maps are mostly
unknown outside the explored area. :func:`relay.fleet.occupancy.from_map_yaml` deliberately counts unknown cells
as occupied (safe for planning), so callers pass the unknown mask separately: :func:`map_yaml_layers` and
:func:`ros_map_layers` return both.

Measured on the 2-core dev box (CPython 3.11, numpy 2.x; load = ``map_yaml_layers``, twin = ``grid_to_glb``):

* warehouse (1006 x 1674 @ 0.03 m, 31 k wall cells): load 0.04 s, twin 0.13 s, 1.3 MB (42 k wall vertices);
* depot (604 x 307 @ 0.05 m): load 0.01 s, twin 0.02 s, 0.6 MB;
* turtlebot3_world and tb3_sandbox (384 x 384 @ 0.05 m): load 0.01 s, twin 0.015 s, 0.13 MB.

A tenth of a second is too long to hold the relay's event loop when a live ``/map`` arrives: run it in a
worker thread, e.g. ``await asyncio.to_thread(grid_to_glb, grid, unknown=unknown)``; the loop keeps running
meanwhile (the GIL is handed over every few milliseconds, and numpy releases it in its array loops).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import NDArray

from ..fleet.occupancy import OccupancyGrid, from_map_yaml, read_pgm
from .gltf import Geometry, Material, Mesh, Node, Primitive, build_glb, merge

__all__ = ["grid_to_glb", "map_yaml_layers", "ros_map_layers"]

_FLOOR = Material("map_floor", (0.55, 0.56, 0.58, 1.0), metallic=0.0, roughness=0.9)
_WALLS = Material("map_walls", (0.45, 0.52, 0.62, 1.0), metallic=0.0, roughness=0.8)
_UNKNOWN = Material("map_unknown", (0.12, 0.12, 0.14, 1.0), metallic=0.0, roughness=1.0)
#: Height of the unknown overlay above the floor: clear of z-fighting, invisible as a step.
_UNKNOWN_Z = 0.003

# Two triangles per quad whose corners are listed counter-clockwise.
_TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)


def _runs(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """Runs of True along each row: ``(row, start, end)`` arrays, ``end`` exclusive, row-major order."""
    rows, cols = mask.shape
    edges = np.zeros((rows, cols + 2), dtype=np.int8)
    edges[:, 1:-1] = mask
    d = np.diff(edges, axis=1)
    # nonzero() is row-major, so the k-th start and the k-th end belong to the same run.
    run_rows, starts = np.nonzero(d == 1)
    _, ends = np.nonzero(d == -1)
    return run_rows, starts, ends


def _rectangles(mask: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Cover the True cells with disjoint rectangles ``[row0, row1) x [col0, col1)``, as an ``(n, 4)`` array.

    Row runs are sorted by (start, end, row); a run that continues the previous one (same span, next row)
    extends its rectangle, anything else starts a new one. Deterministic: the order depends only on the mask.
    """
    rows, starts, ends = _runs(mask)
    if rows.size == 0:
        return np.zeros((0, 4), dtype=np.intp)
    order = np.lexsort((rows, ends, starts))
    r, s, e = rows[order], starts[order], ends[order]
    new = np.ones(r.size, dtype=np.bool_)
    new[1:] = (s[1:] != s[:-1]) | (e[1:] != e[:-1]) | (r[1:] != r[:-1] + 1)
    first = np.flatnonzero(new)
    last = np.append(first[1:], r.size) - 1
    return np.stack([r[first], r[last] + 1, s[first], e[first]], axis=1)


def _quads(corners: NDArray[np.float64], normal: tuple[float, float, float]) -> Geometry | None:
    """Geometry of ``(n, 4, 3)`` quad corners (counter-clockwise from the ``normal`` side); None if n == 0."""
    n = corners.shape[0]
    if n == 0:
        return None
    positions = corners.reshape(-1, 3)
    normals = np.broadcast_to(np.asarray(normal, dtype=np.float64), positions.shape)
    triangles = (4 * np.arange(n)[:, None, None] + _TRIANGLES[None]).reshape(-1, 3)
    return Geometry(positions, normals, triangles)


def _top_quads(rects: NDArray[np.intp], grid: OccupancyGrid, z: float) -> NDArray[np.float64]:
    res, ox, oy = grid.resolution, grid.origin_x, grid.origin_y
    y0 = oy + rects[:, 0] * res
    y1 = oy + rects[:, 1] * res
    x0 = ox + rects[:, 2] * res
    x1 = ox + rects[:, 3] * res
    zz = np.full_like(x0, z)
    return np.stack(
        [np.stack(c, axis=1) for c in ((x0, y0, zz), (x1, y0, zz), (x1, y1, zz), (x0, y1, zz))],
        axis=1,
    )


def _add_faces(
    out: list[Geometry],
    fixed: NDArray[Any],
    start: NDArray[Any],
    stop: NDArray[Any],
    height: float,
    *,
    along_x: bool,
    flip: bool,
    normal: tuple[float, float, float],
) -> None:
    """Vertical quads on boundary lines at ``fixed`` (x, or y when ``along_x``), each spanning ``start`` to
    ``stop`` along the line and 0 to ``height`` up; ``flip`` walks them the other way so they face ``normal``."""
    if flip:
        start, stop = stop, start
    z0, z1 = np.zeros_like(fixed), np.full_like(fixed, height)
    ends = ((start, z0), (stop, z0), (stop, z1), (start, z1))
    points = [(along, fixed, z) if along_x else (fixed, along, z) for along, z in ends]
    corners = np.stack([np.stack(c, axis=1) for c in points], axis=1)
    geom = _quads(corners, normal)
    if geom is not None:
        out.append(geom)


def _side_quads(walls: NDArray[np.bool_], grid: OccupancyGrid, height: float) -> list[Geometry]:
    """The exposed vertical faces of the wall cells, merged along each boundary line."""
    res, ox, oy = grid.resolution, grid.origin_x, grid.origin_y
    rows, cols = walls.shape
    padded = np.zeros((rows + 2, cols + 2), dtype=np.bool_)
    padded[1:-1, 1:-1] = walls
    inner = padded[1:-1, 1:-1]
    out: list[Geometry] = []

    # East/west faces: boundary lines x = const; runs go along y (so work on the transpose). Seen from -x,
    # +y is on the left: the quad is walked from high y to low y (``flip``).
    for dc in (1, -1):
        exposed = inner & ~padded[1:-1, 1 + dc : cols + 1 + dc]
        line, a, b = _runs(np.ascontiguousarray(exposed.T))
        x = ox + (line + (1 if dc > 0 else 0)) * res
        _add_faces(out, x, oy + a * res, oy + b * res, height, along_x=False, flip=dc < 0, normal=(float(dc), 0.0, 0.0))
    # North/south faces: boundary lines y = const; runs go along x. Seen from +y, +x is on the left.
    for dr in (1, -1):
        exposed = inner & ~padded[1 + dr : rows + 1 + dr, 1:-1]
        line, a, b = _runs(exposed)
        y = oy + (line + (1 if dr > 0 else 0)) * res
        _add_faces(out, y, ox + a * res, ox + b * res, height, along_x=True, flip=dr > 0, normal=(0.0, float(dr), 0.0))
    return out


def grid_to_glb(
    grid: OccupancyGrid,
    wall_height: float = 1.0,
    *,
    unknown: NDArray[np.bool_] | None = None,
    name: str = "map",
) -> bytes:
    """The GLB twin of ``grid``: floor plus extruded walls, Y-up, map frame = scene frame.

    Walls are the cells that are occupied in ``grid`` and not ``unknown`` (a boolean mask of the grid's
    shape, row 0 = lowest y); unknown cells are floor, covered by a dark overlay mesh named ``unknown``.
    Nodes: ``floor`` (one quad over :attr:`OccupancyGrid.bounds` at height 0, the client's raycast target),
    ``walls`` (tops at ``wall_height``; absent when there is no wall cell), ``unknown`` (when the mask has any
    non-wall cell). Same input, same bytes.

    Raises ``ValueError`` for a non-positive or non-finite ``wall_height`` or a mask of the wrong shape.
    """
    if not (math.isfinite(wall_height) and wall_height > 0.0):
        raise ValueError(f"wall_height must be a positive finite number, got {wall_height!r}")
    walls = grid.occupied
    hidden: NDArray[np.bool_] | None = None
    if unknown is not None:
        mask = np.asarray(unknown, dtype=np.bool_)
        if mask.shape != walls.shape:
            raise ValueError(f"unknown mask has shape {mask.shape}, the grid {walls.shape}")
        walls = walls & ~mask
        hidden = mask

    min_x, min_y, max_x, max_y = grid.bounds
    floor = Geometry(
        np.array([[min_x, min_y, 0.0], [max_x, min_y, 0.0], [max_x, max_y, 0.0], [min_x, max_y, 0.0]]),
        np.repeat([[0.0, 0.0, 1.0]], 4, axis=0),
        _TRIANGLES,
    )
    nodes = [Node("floor", Mesh("floor", (Primitive(floor, _FLOOR),)), extras={"kind": "floor"})]

    parts: list[Geometry] = []
    top = _quads(_top_quads(_rectangles(walls), grid, wall_height), (0.0, 0.0, 1.0))
    if top is not None:
        parts.append(top)
        parts += _side_quads(walls, grid, wall_height)
        nodes.append(Node("walls", Mesh("walls", (Primitive(merge(parts), _WALLS),)), extras={"kind": "wall"}))

    if hidden is not None:
        overlay = _quads(_top_quads(_rectangles(hidden), grid, _UNKNOWN_Z), (0.0, 0.0, 1.0))
        if overlay is not None:
            mesh = Mesh("unknown", (Primitive(overlay, _UNKNOWN),))
            nodes.append(Node("unknown", mesh, extras={"kind": "unknown"}))
    return build_glb(nodes, scene_name=name)


def map_yaml_layers(path: str | os.PathLike[str]) -> tuple[OccupancyGrid, NDArray[np.bool_]]:
    """Load a map_server map as ``(grid, unknown)`` for :func:`grid_to_glb`.

    ``grid`` is exactly :func:`relay.fleet.occupancy.from_map_yaml`'s (free only below ``free_thresh``, so it
    validates the file and is what the planner sees); ``unknown`` marks the cells that are neither free nor
    above ``occupied_thresh`` (in ``raw`` mode: values above 100, or between the two thresholds), which the
    twin shows as floor rather than walls. Raises ``ValueError`` naming the file, like ``from_map_yaml``.
    """
    grid = from_map_yaml(path)
    yaml_path = Path(path)
    # from_map_yaml has validated every field used below; re-reading the small yaml is cheaper than
    # changing its return type. read_pgm is shared so that both agree on the pixels exactly.
    meta = yaml.safe_load(yaml_path.read_text(encoding="utf-8"))
    image = Path(meta["image"])
    pixels, maxval = read_pgm(image if image.is_absolute() else yaml_path.parent / image)
    occupied_thresh = float(meta["occupied_thresh"])
    if meta.get("mode", "trinary") == "raw":
        percent = np.rint(pixels * (255.0 / maxval))
        lethal = (percent > occupied_thresh * 100.0) & (percent <= 100.0)
    else:
        shade = pixels / float(maxval)
        p = shade if bool(meta["negate"]) else 1.0 - shade
        lethal = p > occupied_thresh
    # Image row 0 is the top of the map; grid row 0 is the bottom.
    unknown = grid.occupied & ~lethal[::-1, :]
    return grid, unknown


def ros_map_layers(
    data: Sequence[int] | NDArray[np.integer],
    width: int,
    height: int,
    resolution: float,
    origin_x: float,
    origin_y: float,
    occupied_threshold: int = 65,
) -> tuple[OccupancyGrid, NDArray[np.bool_]]:
    """``(grid, unknown)`` from the fields of a ``nav_msgs/OccupancyGrid`` (``info.origin`` without rotation).

    ``data`` is row-major with row 0 at ``origin_y`` (the message's own order), values ``-1`` (unknown) or
    ``0..100``. Cells at or above ``occupied_threshold`` (65, map_saver's default ``occupied_thresh``) are
    walls; ``grid`` counts unknown cells as occupied too, as :func:`relay.fleet.occupancy.from_map_yaml` does, and
    ``unknown`` marks them. Raises ``ValueError`` when ``data`` does not hold ``width * height`` values.
    """
    values = np.asarray(data, dtype=np.int16)
    if width < 1 or height < 1 or values.size != width * height:
        raise ValueError(f"map data has {values.size} cells, expected {width} x {height}")
    values = values.reshape(height, width)
    unknown = values < 0
    grid = OccupancyGrid(origin_x, origin_y, resolution, (values >= occupied_threshold) | unknown)
    return grid, unknown
