"""Grid path planning for simulated robots: A* on an inflated, coarsened grid plus string pulling.

Pipeline (all in the map frame, metres):

1. Inflate the plain grid by the robot radius ("hard" grid: the robot centre
   must stay in its free cells) and by a few larger radii to get a
   *clearance level* per cell (0 = forbidden, ``_LEVELS`` = comfortable).
2. Coarsen by an integer factor (a coarse cell is as bad as its worst fine
   cell, so coarse-free implies fine-free) to keep pure-Python A* fast.
3. A* 8-connected, octile heuristic, no corner cutting; stepping into a cell
   with less clearance costs more, so paths keep off walls where there is
   room (a path hugging the hard boundary would leave no margin for the
   follower, whose bumper radius is smaller than the planning radius).
4. String pulling: replace runs of cells by straight segments when the
   segment keeps at least the clearance the replaced cells had.

Measured on the 2-core dev box (CPython 3.11, numpy 2.x), see
``tests/test_sim_world.py`` for the cases:

* demo facility (360 x 200 cells @ 0.05 m, coarsened x3): ``Planner``
  build 3-5 ms; spawn -> room-centre plans 1-12 ms (mean 2-3 ms); the
  worst corner-to-corner plan ~11 ms; one-shot ``plan_path`` ~10 ms.
  Without coarsening the corner-to-corner plan took ~150 ms.
* turtlebot3_world (384 x 384 @ 0.05 m, coarsened x3): map load ~2 ms,
  ``Planner`` build ~5 ms, plans across the arena ~1 ms, one-shot
  ``plan_path`` ~6 ms.
* An unreachable goal is rejected from precomputed connected components
  (~0.1 ms) instead of by exhausting the search (~250 ms).
"""

from __future__ import annotations

import bisect
import heapq
import math

import numpy as np
from numpy.typing import NDArray

from ..fleet.occupancy import OccupancyGrid

__all__ = ["NoPathError", "Planner", "plan_path"]

Point = tuple[float, float]

_SQRT2 = math.sqrt(2.0)
# Clearance levels above the robot radius: cells closer than
# robot_radius + k * _LEVEL_STEP to an obstacle get level k (k < _LEVELS).
_LEVELS = 3
_LEVEL_STEP = 0.1
# Extra cost per missing clearance level, relative to a unit step. 0.5 makes
# hugging a wall up to 2x as expensive as open floor: enough to centre paths
# in rooms and doorways without long detours.
_LEVEL_PENALTY = 0.5
# Coarse cells of about this size keep A* on an 18 x 10 m floor to a few
# thousand expansions while a 0.9 m wide free doorway still spans several cells.
_TARGET_COARSE_RES = 0.15


class NoPathError(ValueError):
    """No acceptable path exists; the message says why in operator terms."""


def _fmt(p: Point) -> str:
    return f"({p[0]:.2f}, {p[1]:.2f})"


class _Level:
    """One resolution level of the search: padded flat arrays for A*."""

    def __init__(self, level: NDArray[np.int8], factor: int, grid: OccupancyGrid) -> None:
        rows, cols = (int(n) for n in level.shape)
        crow = -(-rows // factor)
        ccol = -(-cols // factor)
        # Pad to whole blocks with level 0 (off-map is forbidden), then take
        # the worst fine cell per block so coarse-free implies fine-free.
        padded = np.zeros((crow * factor, ccol * factor), dtype=np.int8)
        padded[:rows, :cols] = level
        coarse = padded.reshape(crow, factor, ccol, factor).min(axis=(1, 3))
        self.factor = factor
        self.rows = crow
        self.cols = ccol
        self.cell = grid.resolution * factor
        self.origin_x = grid.origin_x
        self.origin_y = grid.origin_y
        self.level = coarse
        # One-cell forbidden border so neighbour indices never leave the array.
        self.stride = ccol + 2
        border = np.zeros((crow + 2, ccol + 2), dtype=np.int8)
        border[1:-1, 1:-1] = coarse
        flat = border.ravel()
        self.blocked: bytes = (flat == 0).tobytes()
        cost = 1.0 + _LEVEL_PENALTY * (_LEVELS - flat.astype(np.float64))
        self.cost: list[float] = cost.tolist()
        s = self.stride
        # (offset, step length, two orthogonal offsets that must be free to
        # allow a diagonal step -- no cutting past an obstacle corner).
        self.moves: tuple[tuple[int, float, int, int], ...] = (
            (1, 1.0, 0, 0),
            (-1, 1.0, 0, 0),
            (s, 1.0, 0, 0),
            (-s, 1.0, 0, 0),
            (s + 1, _SQRT2, s, 1),
            (s - 1, _SQRT2, s, -1),
            (-s + 1, _SQRT2, -s, 1),
            (-s - 1, _SQRT2, -s, -1),
        )

    def cell_of(self, p: Point) -> tuple[int, int]:
        """(row, col) of the coarse cell containing ``p`` (may be out of range)."""
        return (
            math.floor((p[1] - self.origin_y) / self.cell),
            math.floor((p[0] - self.origin_x) / self.cell),
        )

    def centre(self, row: int, col: int) -> Point:
        return (
            self.origin_x + (col + 0.5) * self.cell,
            self.origin_y + (row + 0.5) * self.cell,
        )

    def index(self, row: int, col: int) -> int:
        return (row + 1) * self.stride + col + 1

    def row_col(self, index: int) -> tuple[int, int]:
        r, c = divmod(index, self.stride)
        return r - 1, c - 1

    def is_free(self, row: int, col: int) -> bool:
        return 0 <= row < self.rows and 0 <= col < self.cols and bool(self.level[row, col] > 0)

    def nearest_free(self, p: Point) -> tuple[int, int] | None:
        """Free coarse cell whose centre is nearest to ``p`` (vectorised scan)."""
        rr, cc = np.nonzero(self.level > 0)
        if rr.size == 0:
            return None
        dx = self.origin_x + (cc + 0.5) * self.cell - p[0]
        dy = self.origin_y + (rr + 0.5) * self.cell - p[1]
        k = int(np.argmin(dx * dx + dy * dy))
        return int(rr[k]), int(cc[k])

    def astar(self, start: int, goal: int) -> list[int] | None:
        """8-connected A* from flat index ``start`` to ``goal``; None if unreachable.

        Pure Python over flat lists/bytes: per-element numpy indexing would
        be ~10x slower than list access here.
        """
        stride = self.stride
        blocked = self.blocked
        cost = self.cost
        moves = self.moves
        closed = bytearray(blocked)  # forbidden cells start out "closed"
        g = [math.inf] * len(blocked)
        parent = [-1] * len(blocked)
        goal_r, goal_c = divmod(goal, stride)
        diag_bonus = _SQRT2 - 2.0
        g[start] = 0.0
        # Entries (f, h, index): ties on f go to the smaller h, i.e. deeper
        # nodes first, which on open floor expands little more than the path.
        heap: list[tuple[float, float, int]] = [(0.0, 0.0, start)]
        while heap:
            _, _, idx = heapq.heappop(heap)
            if idx == goal:
                path = [idx]
                while idx != start:
                    idx = parent[idx]
                    path.append(idx)
                path.reverse()
                return path
            if closed[idx]:
                continue
            closed[idx] = 1
            g0 = g[idx]
            for off, length, side_a, side_b in moves:
                n = idx + off
                if closed[n]:
                    continue
                if side_a and (blocked[idx + side_a] or blocked[idx + side_b]):
                    continue
                ng = g0 + length * cost[n]
                if ng < g[n]:
                    g[n] = ng
                    parent[n] = idx
                    r, c = divmod(n, stride)
                    dr = r - goal_r if r > goal_r else goal_r - r
                    dc = c - goal_c if c > goal_c else goal_c - c
                    h = dr + dc + diag_bonus * min(dr, dc)
                    heapq.heappush(heap, (ng + h, h, n))
        return None


class _Components:
    """4-connected components of the free cells, labelled run by run.

    8-connected moves without corner cutting connect exactly what
    4-connectivity connects, so equal labels mean "A* at full resolution
    would find a path". Labelling horizontal runs with a union-find costs a
    few ms even for 384 x 384 and lets an unreachable goal be rejected at
    once instead of after exhausting two searches (~250 ms on the facility).
    """

    def __init__(self, free: NDArray[np.bool_]) -> None:
        rows, cols = (int(n) for n in free.shape)
        edges = np.zeros((rows, cols + 2), dtype=np.int8)
        edges[:, 1:-1] = free
        d = np.diff(edges, axis=1)
        # nonzero() is row-major, so runs come grouped by row, left to right,
        # and the k-th start pairs with the k-th end.
        run_rows, starts = np.nonzero(d == 1)
        _, ends = np.nonzero(d == -1)
        self._starts: list[int] = starts.tolist()
        self._ends: list[int] = ends.tolist()  # exclusive
        self._offsets: list[int] = np.concatenate(([0], np.cumsum(np.bincount(run_rows, minlength=rows)))).tolist()
        parent = list(range(len(self._starts)))

        def find(k: int) -> int:
            while parent[k] != k:
                parent[k] = parent[parent[k]]
                k = parent[k]
            return k

        for r in range(1, rows):
            i, i_end = self._offsets[r], self._offsets[r + 1]
            j, j_end = self._offsets[r - 1], self._offsets[r]
            while i < i_end and j < j_end:
                if self._starts[i] < self._ends[j] and self._starts[j] < self._ends[i]:
                    a, b = find(i), find(j)
                    if a != b:
                        parent[a] = b
                # Advance whichever run finishes first; it cannot overlap later ones.
                if self._ends[i] < self._ends[j]:
                    i += 1
                else:
                    j += 1
        self._labels = [find(k) for k in range(len(parent))]

    def label(self, row: int, col: int) -> int | None:
        """Component of cell ``(row, col)``; None if blocked or out of range."""
        if not 0 <= row < len(self._offsets) - 1:
            return None
        lo, hi = self._offsets[row], self._offsets[row + 1]
        k = bisect.bisect_right(self._starts, col, lo, hi) - 1
        if k >= lo and col < self._ends[k]:
            return self._labels[k]
        return None


class Planner:
    """Plans collision-free paths on one grid for one robot radius.

    Construction does the O(grid) work (inflation, clearance levels,
    coarsening) once; :meth:`plan` is then cheap. Hold one per (grid, radius)
    -- the grid is immutable, so a Planner never goes stale. :meth:`plan`
    keeps its search state local (the only shared write is an idempotent,
    lazily built full-resolution table), so it may run in worker threads,
    e.g. via ``asyncio.to_thread``.

    Attributes:
        grid: the plain occupancy grid.
        robot_radius: metres; the path centre line stays more than this far
            from occupied cell centres (in the inflated grid's sense).
        inflated: ``grid.inflate(robot_radius)``; every returned segment is
            free in it (except the first hop out of an obstacle when the
            start itself is not, see :meth:`plan`).
    """

    def __init__(self, grid: OccupancyGrid, robot_radius: float = 0.25, coarsen: int | None = None) -> None:
        """Prepare planning on ``grid``.

        ``coarsen`` is the integer coarsening factor; ``None`` picks one so
        coarse cells are about 0.15 m. ``ValueError`` for a negative radius
        or a factor < 1.
        """
        if not (math.isfinite(robot_radius) and robot_radius >= 0.0):
            raise ValueError(f"robot_radius must be finite and >= 0, got {robot_radius!r}")
        if coarsen is None:
            coarsen = max(1, math.floor(_TARGET_COARSE_RES / grid.resolution + 1e-9))
        if coarsen < 1:
            raise ValueError(f"coarsen must be >= 1, got {coarsen}")
        self.grid = grid
        self.robot_radius = robot_radius
        self.inflated = grid.inflate(robot_radius)
        level = (~self.inflated.occupied).astype(np.int8)
        for k in range(1, _LEVELS):
            level += ~grid.inflate(robot_radius + k * _LEVEL_STEP).occupied
        # Fine clearance level per cell: 0 forbidden .. _LEVELS comfortable.
        self._level: NDArray[np.int8] = level
        self._components = _Components(level > 0)
        self._coarse = _Level(level, coarsen, grid)
        # Full-resolution search arrays are only needed for the rare retry
        # (see plan), so they are built on first use rather than up front.
        self._fine: _Level | None = None

    def plan(self, start: Point, goal: Point) -> list[Point]:
        """Return waypoints from ``start`` to ``goal`` (metres); first is ``start``, last is ``goal``, exactly.

        * ``goal`` off the map, inside an obstacle, or closer than
          ``robot_radius`` to one raises :class:`NoPathError`.
        * ``start`` off the map raises :class:`NoPathError`; a start inside
          the inflated obstacle zone (robot touching a wall) is allowed: the
          path first hops to the nearest free cell.
        * Unreachable goals raise :class:`NoPathError`.

        All segments after that optional first hop are free in
        :attr:`inflated` and keep the clearance of the A* cells they replace.
        """
        start = (float(start[0]), float(start[1]))
        goal = (float(goal[0]), float(goal[1]))
        if not self.grid.in_bounds(*goal):
            raise NoPathError(f"goal {_fmt(goal)} is outside the map {self._bounds_text()}")
        if not self.grid.is_free(*goal):
            raise NoPathError(f"goal {_fmt(goal)} is inside an obstacle")
        if not self.inflated.is_free(*goal):
            raise NoPathError(
                f"goal {_fmt(goal)} is within the robot radius ({self.robot_radius:.2f} m) "
                "of an obstacle; pick a point further from walls"
            )
        if not self.grid.in_bounds(*start):
            raise NoPathError(f"start {_fmt(start)} is outside the map {self._bounds_text()}")

        goal_label = self._components.label(*self.grid.world_to_cell(*goal))
        start_label = self._components.label(*self.grid.world_to_cell(*start))
        if start_label is not None and start_label != goal_label:
            raise NoPathError(f"no path from {_fmt(start)} to {_fmt(goal)}: the goal is not reachable")
        path = self._plan_level(self._coarse, start, goal)
        if path is None and self._coarse.factor > 1:
            # Coarsening can close a passage only a little wider than the
            # robot; retry at full resolution before giving up (slower, but
            # only on this rare path).
            if self._fine is None:
                self._fine = _Level(self._level, 1, self.grid)
            path = self._plan_level(self._fine, start, goal)
        if path is None:
            raise NoPathError(f"no path from {_fmt(start)} to {_fmt(goal)}: the goal is not reachable")
        return path

    def _bounds_text(self) -> str:
        x0, y0, x1, y1 = self.grid.bounds
        return f"(x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f})"

    def _plan_level(self, lvl: _Level, start: Point, goal: Point) -> list[Point] | None:
        """Plan on one level; None if this level cannot connect start and goal."""
        start_free = self.inflated.is_free(*start)
        s_rc = lvl.cell_of(start)
        start_snapped = not lvl.is_free(*s_rc)
        if start_snapped:
            snapped = lvl.nearest_free(start)
            if snapped is None:
                return None
            # A free start whose coarse block merely touches the margin must
            # reach the snapped cell by a free hop; otherwise let the caller
            # retry at full resolution, where no snapping is needed.
            if start_free and not self.inflated.segment_free(*start, *lvl.centre(*snapped)):
                return None
            s_rc = snapped
        g_rc = lvl.cell_of(goal)
        goal_snapped = not lvl.is_free(*g_rc)
        if goal_snapped:
            # The goal is free (checked by plan) but its coarse block touches the margin.
            snapped = lvl.nearest_free(goal)
            if snapped is None or not self.inflated.segment_free(*lvl.centre(*snapped), *goal):
                return None
            g_rc = snapped
        cells = lvl.astar(lvl.index(*s_rc), lvl.index(*g_rc))
        if cells is None:
            return None
        if len(cells) == 1 and not start_snapped and not goal_snapped:
            return [start, goal]  # same free cell: a straight hop
        points = [lvl.centre(*lvl.row_col(i)) for i in cells]
        prefix: list[Point] = []
        if not start_snapped:
            points[0] = start  # inside the first (free) cell: the hop is free
        elif start_free:
            points.insert(0, start)
        else:
            # Robot overlaps the inflated zone: hop straight out to the
            # nearest free cell first. That hop cannot be free by definition,
            # so it is kept out of string pulling.
            prefix = [start]
        if goal_snapped:
            points.append(goal)
        else:
            points[-1] = goal
        return prefix + self._string_pull(points)

    def _point_level(self, p: Point) -> int:
        row, col = self.grid.world_to_cell(*p)
        if 0 <= row < self.grid.height and 0 <= col < self.grid.width:
            return int(self._level[row, col])
        return 0

    def _segment_ok(self, a: Point, b: Point, need: int) -> bool:
        """True when ``a -> b`` is hard-free and clear enough (same sampling as ``segment_free``).

        A sample must reach level ``need`` unless it is near an endpoint:
        clearance changes at most 1 m per metre travelled, so within ``d`` of
        an endpoint of level ``l`` only ``l + floor(d / _LEVEL_STEP)`` can be
        demanded. This lets a start or goal close to a wall connect directly
        while a long shortcut still may not graze walls that the A* cells
        avoided.
        """
        grid = self.grid
        dx = b[0] - a[0]
        dy = b[1] - a[1]
        length = math.hypot(dx, dy)
        n = max(1, math.ceil(length / (0.5 * grid.resolution)))
        t = np.linspace(0.0, 1.0, n + 1)
        cols = np.floor((a[0] + t * dx - grid.origin_x) / grid.resolution).astype(np.intp)
        rows = np.floor((a[1] + t * dy - grid.origin_y) / grid.resolution).astype(np.intp)
        if cols.min() < 0 or rows.min() < 0 or cols.max() >= grid.width or rows.max() >= grid.height:
            return False
        got = self._level[rows, cols]
        steps_a = np.floor(t * (length / _LEVEL_STEP))
        steps_b = np.floor((1.0 - t) * (length / _LEVEL_STEP))
        allowance = np.minimum(got[0] + steps_a, got[-1] + steps_b)
        required = np.maximum(np.minimum(allowance, need), 1)
        return bool(np.all(got >= required))

    def _string_pull(self, points: list[Point]) -> list[Point]:
        """Greedy line-of-sight shortening that does not lower clearance.

        From each anchor, extend to the farthest consecutive candidate whose
        straight segment is hard-free and at least as clear as the worst
        point it replaces (see :meth:`_segment_ok`). Only direction changes
        of the cell path are candidates: points inside a straight run add
        nothing.
        """
        if len(points) <= 2:
            return list(points)
        keep = [0]
        for i in range(1, len(points) - 1):
            d_prev = (points[i][0] - points[i - 1][0], points[i][1] - points[i - 1][1])
            d_next = (points[i + 1][0] - points[i][0], points[i + 1][1] - points[i][1])
            cross = d_prev[0] * d_next[1] - d_prev[1] * d_next[0]
            if abs(cross) > 1e-12 or d_prev[0] * d_next[0] + d_prev[1] * d_next[1] < 0.0:
                keep.append(i)
        keep.append(len(points) - 1)
        levels = [self._point_level(p) for p in points]
        corners = [points[i] for i in keep]
        corner_level = [levels[i] for i in keep]
        # Worst level strictly inside each straight run between corners.
        run_level = [min(levels[keep[k] + 1 : keep[k + 1]], default=_LEVELS) for k in range(len(keep) - 1)]
        out = [corners[0]]
        i = 0
        last = len(corners) - 1
        while i < last:
            best = i + 1
            need = run_level[i]
            for k in range(i + 2, last + 1):
                need = min(need, corner_level[k - 1], run_level[k - 1])
                if self._segment_ok(corners[i], corners[k], need):
                    best = k
                else:
                    break
            out.append(corners[best])
            i = best
        return out


def plan_path(
    grid: OccupancyGrid,
    start: Point,
    goal: Point,
    robot_radius: float = 0.25,
) -> list[Point]:
    """One-shot convenience: ``Planner(grid, robot_radius).plan(start, goal)``.

    Re-does the inflation each call (a few ms); callers planning repeatedly
    on the same grid should keep a :class:`Planner`. Raises
    :class:`NoPathError` as :meth:`Planner.plan` does.
    """
    return Planner(grid, robot_radius).plan(start, goal)
