"""Where an operator should stand to see the fleet: the VR client's starting place (``hello.vantage``).

An operator who enters VR facing a wall, one robot in sight, is lost before the first click. The place is chosen
on the map grid (pure, no I/O): among free spots with room to stand, the one that sees the most robots (an
unbroken line of sight over the grid, at least ``NEAR`` away) within a field of view a headset shows without
turning (``HALF_FOV`` either side of the facing), then the one whose robots fill that view best, so that none is
hidden behind another or tiny. The facing points at the middle of the robots it sees. Deterministic: the same grid
and poses give the same place.

Measured on the demo facility (360 x 200 cells, 720 candidates, three robots): about 4 ms quiet (30 ms with the
browser tests beside it); at most MAX_CANDIDATES spots on any map; cached per robot layout (poses rounded to the
candidate spacing), so a reconnecting client costs nothing. A large fleet is judged by an even sample of at most
MAX_ROBOTS of its robots, over at most SIGHT_BUDGET lines of sight (fewer spots for more robots): with 100 robots
every hello searched 44 000 lines of sight, 3 s of the event loop per connecting client; now ~2 000, 0.1 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Final

from .occupancy import OccupancyGrid

#: Candidate spots are this far apart, metres, or wider on a large map: hello is built on the event loop, so the
#: search is bounded to MAX_CANDIDATES spots whatever the map (a 200 x 200 m site at 0.5 m would be 160 000).
SPACING: Final = 0.5
MAX_CANDIDATES: Final = 1500
#: Room to stand: no wall within this of the spot, metres.
STANDING_CLEARANCE: Final = 0.5
#: Robots nearer than this are too close to see with the others (and to stand beside safely), metres.
NEAR: Final = 1.5
#: Robots judged at most (an even sample of the fleet in name order), and lines of sight searched at most (spots x
#: robots; ~57 us each on the demo grid): the demo's 720 spots x 3 robots fit, a large fleet gets wider spacing.
MAX_ROBOTS: Final = 12
SIGHT_BUDGET: Final = 2500
#: Half of the horizontal field of view the robots should fit in: a Quest 3 shows about 110 degrees; 40 leaves margin.
HALF_FOV: Final = math.radians(40.0)


@dataclass(frozen=True, slots=True)
class Vantage:
    x: float
    y: float
    yaw: float  # map frame, counter-clockwise from +x
    sees: tuple[str, ...]  # the robots in view from there


def vantage(grid: OccupancyGrid, robots: dict[str, tuple[float, float]]) -> Vantage | None:
    """The best place to see ``robots`` (name -> map position) from; None without robots or a free spot."""
    if not robots:
        return None
    min_x, min_y, max_x, max_y = grid.bounds
    names = sorted(robots)
    if len(names) > MAX_ROBOTS:
        names = [names[int(k * len(names) / MAX_ROBOTS)] for k in range(MAX_ROBOTS)]
    candidates = min(MAX_CANDIDATES, SIGHT_BUDGET // len(names))
    spacing = SPACING * max(1, math.ceil(math.sqrt((max_x - min_x) * (max_y - min_y) / candidates) / SPACING))
    layout = tuple((name, round(robots[name][0] / spacing), round(robots[name][1] / spacing)) for name in names)
    return _vantage(grid, layout, spacing)


@lru_cache(maxsize=16)
def _vantage(grid: OccupancyGrid, layout: tuple[tuple[str, int, int], ...], spacing: float) -> Vantage | None:
    robots = {name: (gx * spacing, gy * spacing) for name, gx, gy in layout}
    min_x, min_y, max_x, max_y = grid.bounds
    best: tuple[tuple[int, float, float], Vantage] | None = None
    nx = int((max_x - min_x) / spacing)
    ny = int((max_y - min_y) / spacing)
    for i in range(nx):
        for j in range(ny):
            x = min_x + (i + 0.5) * spacing
            y = min_y + (j + 0.5) * spacing
            if grid.clearance(x, y, STANDING_CLEARANCE) < STANDING_CLEARANCE:
                continue
            seen = {
                name: (rx, ry)
                for name, (rx, ry) in robots.items()
                if math.hypot(rx - x, ry - y) >= NEAR and _sight(grid, x, y, rx, ry)
            }
            if not seen:
                continue
            view = _view(x, y, seen)
            if view is None:
                continue
            yaw, fill, names = view
            # More robots first; then robots filling the view (not bunched in its middle, far away); then the
            # spot nearest the robots' middle (a shorter walk to them). Ties keep the first spot: deterministic.
            cx = sum(p[0] for p in seen.values()) / len(seen)
            cy = sum(p[1] for p in seen.values()) / len(seen)
            score = (len(names), round(fill, 2), -math.hypot(cx - x, cy - y))
            if best is None or score > best[0]:
                best = (score, Vantage(round(x, 3), round(y, 3), round(yaw, 4), names))
    return None if best is None else best[1]


def _sight(grid: OccupancyGrid, x0: float, y0: float, x1: float, y1: float) -> bool:
    """A line of sight over the grid, stopping short of the robot's own cell (a robot may stand beside a wall)."""
    length = math.hypot(x1 - x0, y1 - y0)
    shorten = min(0.3, length) / length if length > 0 else 0.0
    return grid.segment_free(x0, y0, x1 - (x1 - x0) * shorten, y1 - (y1 - y0) * shorten)


def _view(x: float, y: float, seen: dict[str, tuple[float, float]]) -> tuple[float, float, tuple[str, ...]] | None:
    """The facing that fits the most of ``seen`` within HALF_FOV, how much of the view they span (0..1), and who."""
    bearings = sorted((math.atan2(ry - y, rx - x), name) for name, (rx, ry) in seen.items())
    best: tuple[int, float, float, tuple[str, ...]] | None = None
    for start, _ in bearings:
        inside = [(b, n) for b, n in bearings if 0.0 <= math.remainder(b - start, math.tau) % math.tau <= 2 * HALF_FOV]
        spread = max(math.remainder(b - start, math.tau) % math.tau for b, _ in inside)
        yaw = math.remainder(start + spread / 2, math.tau)
        names = tuple(sorted(n for _, n in inside))
        candidate = (len(inside), spread / (2 * HALF_FOV), yaw, names)
        if best is None or candidate[:2] > best[:2]:
            best = candidate
    if best is None:
        return None
    return best[2], best[1], best[3]
