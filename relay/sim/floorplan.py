"""The demo facility as plain data: the single source of truth for its geometry.

The simulator rasterises it for planning and bumping; tools/build_scene.py
extrudes the same boxes into glTF (relay/twin/facility.py), so every solid thing is an axis-aligned
:class:`Box` with a height, in the map frame (REP 103: x east, y north,
z up, metres; floor at z = 0).

Layout (18 m x 10 m)::

    y=10 +-----------------+-----------------+-----------------+
         | chemical_storage| power_distrib.  |    plumbing     |
         |  barrels W + N  |  3 panels on N  | pipe support    |
    y=3  +------+ door +---+-----+ door +----+------+ door +---+
         |                   corridor                          |
    y=0  +-------------------------------------------------------+
        x=0    x=3        x=6      x=9      x=12     x=15       x=18

Rooms connect only through the corridor (dividers at x = 6 and x = 12 have
no doors), which is what makes path planning non-trivial.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..fleet.occupancy import OccupancyGrid
from .hazards import HazardSource

__all__ = [
    "EDGE_SEGMENTS",
    "EDGE_WOBBLE",
    "Box",
    "Decal",
    "FloorPlan",
    "Pipe",
    "Room",
    "Spawn",
    "demo_facility",
    "edge_radius",
    "rasterise",
    "room_named",
    "spawn_of",
]

# Shared geometry constants of the demo facility. Module-level constants are
# immutable values (floats), not state.
_WIDTH = 18.0
_DEPTH = 10.0
_WALL = 0.2
_WALL_HEIGHT = 2.5
_CORRIDOR_Y = 3.0  # centre line of the corridor wall
_DIVIDERS_X = (6.0, 12.0)
_DOOR_CENTRES_X = (3.0, 9.0, 15.0)
_DOOR_WIDTH = 1.4
_DOOR_HEIGHT = 2.1


class _Footprint:
    """The map-frame rectangle ``min_x..max_x`` x ``min_y..max_y`` of a box or a room."""

    min_x: float
    min_y: float
    max_x: float
    max_y: float

    @property
    def centre(self) -> tuple[float, float]:
        """Centre of the rectangle ``(x, y)``."""
        return (0.5 * (self.min_x + self.max_x), 0.5 * (self.min_y + self.max_y))

    def contains(self, x: float, y: float) -> bool:
        """True when ``(x, y)`` lies in the closed rectangle."""
        return self.min_x <= x <= self.max_x and self.min_y <= y <= self.max_y


@dataclass(frozen=True)
class Box(_Footprint):
    """A solid axis-aligned box standing on the floor.

    Contract: ``min_x < max_x``, ``min_y < max_y``, ``height > 0`` (metres).
    ``kind`` is a free-form tag used by renderers and tests, e.g. ``"wall"``,
    ``"barrel"``, ``"panel"``, ``"pipe_support"``, ``"door"``.
    """

    name: str
    min_x: float
    min_y: float
    max_x: float
    max_y: float
    height: float
    kind: str

    def __post_init__(self) -> None:
        if not (self.min_x < self.max_x and self.min_y < self.max_y and self.height > 0.0):
            raise ValueError(f"box {self.name!r} has non-positive extent")


@dataclass(frozen=True)
class Room(_Footprint):
    """A named area; ``title`` is the human-readable label shown to operators.

    Bounds are the nominal (wall-centre-ish) extents, so they include the
    walls around the room; use :attr:`centre` for a safe goal (kept clear of obstacles by design).
    """

    name: str
    title: str
    min_x: float
    min_y: float
    max_x: float
    max_y: float


@dataclass(frozen=True)
class Spawn:
    """Initial pose of a simulated robot: map position and yaw (rad, CCW from +x)."""

    robot: str
    x: float
    y: float
    yaw: float


#: The roughened edge of a decal: its outline at ellipse parameter ``t`` lies at ``1 + sum(a * sin(k * t + p))``
#: times the nominal ellipse, for each ``(a, k, p)`` here, within +-23 % (inside the 1.25x :class:`Decal` allows).
#: The twin's mesh (relay/twin/facility_glb.py) and the grown spill the simulator paints (relay/sim/spill.py)
#: both follow it, so a grown spill is the twin's outline scaled.
EDGE_WOBBLE = ((0.12, 3, 0.7), (0.07, 5, 2.1), (0.04, 8, 0.3))
#: The twin's outline of a decal has a vertex at each of this many equal steps of ``t``, joined by straight edges.
EDGE_SEGMENTS = 48


def edge_radius(t: float) -> float:
    """The roughened outline's radius at ellipse parameter ``t`` (rad), as a multiple of the nominal ellipse's."""
    r = 1.0
    for amplitude, k, phase in EDGE_WOBBLE:  # summed in this order, the twin's glb keeps its bytes
        r += amplitude * math.sin(k * t + phase)
    return r


@dataclass(frozen=True)
class Decal:
    """A flat marking on the floor (a spill, a puddle): visual only, never an obstacle.

    The outline is an ellipse centred on ``(x, y)`` with semi-axes
    ``radius_x`` / ``radius_y`` before rotating it by ``angle`` (rad, CCW
    from +x); renderers may roughen its edge but stay within ``1.25x`` of the
    nominal radii. ``kind`` is a free-form tag (``"spill"``, ``"puddle"``).
    Contract: radii > 0.
    """

    name: str
    kind: str
    x: float
    y: float
    radius_x: float
    radius_y: float
    angle: float = 0.0

    def __post_init__(self) -> None:
        if not (self.radius_x > 0.0 and self.radius_y > 0.0):
            raise ValueError(f"decal {self.name!r} needs positive radii")

    def contains(self, x: float, y: float) -> bool:
        """True when ``(x, y)`` lies in the closed nominal ellipse."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        dx, dy = x - self.x, y - self.y
        u = (c * dx + s * dy) / self.radius_x
        v = (-s * dx + c * dy) / self.radius_y
        return u * u + v * v <= 1.0


@dataclass(frozen=True)
class Pipe:
    """A horizontal overhead pipe along x: visual only (robots pass beneath it).

    It runs from ``x0`` to ``x1`` at ``(y, z)`` with ``radius`` (metres), and
    leaks at ``leak_x`` (``x0 <= leak_x <= x1``), from where it drips onto the floor.
    """

    name: str
    x0: float
    x1: float
    y: float
    z: float
    radius: float
    leak_x: float

    def __post_init__(self) -> None:
        if not (self.x0 < self.x1 and self.radius > 0.0 and self.z > self.radius):
            raise ValueError(f"pipe {self.name!r} has a bad extent")
        if not self.x0 <= self.leak_x <= self.x1:
            raise ValueError(f"pipe {self.name!r} leaks outside its length")


@dataclass(frozen=True)
class FloorPlan:
    """A whole facility. ``doors`` are the openings (not solid), kept for tests and rendering.

    The building occupies ``x in [0, width]``, ``y in [0, depth]``; outer
    walls lie inside that rectangle. ``decals`` (floor markings) and
    ``pipes`` (overhead) are visual only: :func:`rasterise` ignores them.
    ``hazards`` are the sources of the simulated sensor fields (the scene
    file carries them to the simulator; robots.yaml's ``sim.hazards`` holds
    the same values).
    """

    width: float
    depth: float
    wall_thickness: float
    walls: tuple[Box, ...]
    obstacles: tuple[Box, ...]
    rooms: tuple[Room, ...]
    spawns: tuple[Spawn, ...]
    doors: tuple[Box, ...]
    decals: tuple[Decal, ...] = ()
    pipes: tuple[Pipe, ...] = ()
    hazards: tuple[HazardSource, ...] = ()

    @property
    def solids(self) -> tuple[Box, ...]:
        """Every box a robot can collide with (walls then obstacles)."""
        return self.walls + self.obstacles

    def room(self, name: str) -> Room:
        """Return the room called ``name``; ``KeyError`` if there is none."""
        return room_named(self.rooms, name)

    def spawn(self, robot: str) -> Spawn:
        """Return the spawn of ``robot``; ``KeyError`` if there is none."""
        return spawn_of(self.spawns, robot)


def room_named(rooms: tuple[Room, ...], name: str, where: str = "") -> Room:
    """The room of ``rooms`` called ``name``; ``KeyError`` naming it (and ``where``, e.g. `` in <file>``)
    if there is none. Shared by the floor plan and the scene file the simulator loads."""
    for room in rooms:
        if room.name == name:
            return room
    raise KeyError(f"no room named {name!r}{where}")


def spawn_of(spawns: tuple[Spawn, ...], robot: str, where: str = "") -> Spawn:
    """The spawn of ``robot`` among ``spawns``; ``KeyError`` naming it (and ``where``) if there is none."""
    for spawn in spawns:
        if spawn.robot == robot:
            return spawn
    raise KeyError(f"no spawn for robot {robot!r}{where}")


def _square(name: str, kind: str, cx: float, cy: float, size: float, height: float) -> Box:
    half = 0.5 * size
    return Box(name, cx - half, cy - half, cx + half, cy + half, height, kind)


def _walls() -> tuple[tuple[Box, ...], tuple[Box, ...]]:
    """Build walls and door openings from the layout constants."""
    t = _WALL
    h = _WALL_HEIGHT
    half_t = 0.5 * t
    walls: list[Box] = [
        Box("wall_south", 0.0, 0.0, _WIDTH, t, h, "wall"),
        Box("wall_north", 0.0, _DEPTH - t, _WIDTH, _DEPTH, h, "wall"),
        Box("wall_west", 0.0, t, t, _DEPTH - t, h, "wall"),
        Box("wall_east", _WIDTH - t, t, _WIDTH, _DEPTH - t, h, "wall"),
    ]
    # Corridor wall: solid runs between the door openings.
    y0, y1 = _CORRIDOR_Y - half_t, _CORRIDOR_Y + half_t
    doors: list[Box] = []
    run_start = t
    room_names = ("chemical_storage", "power_distribution", "plumbing")
    for index, (cx, room) in enumerate(zip(_DOOR_CENTRES_X, room_names, strict=True)):
        d0, d1 = cx - 0.5 * _DOOR_WIDTH, cx + 0.5 * _DOOR_WIDTH
        walls.append(Box(f"wall_corridor_{index}", run_start, y0, d0, y1, h, "wall"))
        doors.append(Box(f"door_{room}", d0, y0, d1, y1, _DOOR_HEIGHT, "door"))
        run_start = d1
    walls.append(Box(f"wall_corridor_{len(_DOOR_CENTRES_X)}", run_start, y0, _WIDTH - t, y1, h, "wall"))
    for x in _DIVIDERS_X:
        walls.append(Box(f"wall_divider_{x:g}", x - half_t, y1, x + half_t, _DEPTH - t, h, "wall"))
    return tuple(walls), tuple(doors)


def demo_facility() -> FloorPlan:
    """Return the demo facility (see the module docstring for the layout).

    Guarantees relied on by the simulator and its tests: room centres, door
    openings and spawns are free; rooms connect only through the corridor;
    obstacles hug the walls so that every spot at least 1 m from any
    obstacle is reachable. The chemical spill at (1.8, 8.2) and the puddle
    at (15.6, 7.6) are floor markings, not obstacles; the exhaust pipe runs
    overhead and only its support column is solid.
    """
    walls, doors = _walls()
    barrel_h = 0.9
    obstacles = (
        # Chemical storage: barrels along the west and north walls; the
        # leaking one sits in the north-west corner above the spill.
        _square("barrel_1", "barrel", 0.6, 5.6, 0.6, barrel_h),
        _square("barrel_2", "barrel", 0.6, 6.8, 0.6, barrel_h),
        _square("barrel_leaking", "barrel", 1.0, 8.9, 0.6, barrel_h),
        _square("barrel_4", "barrel", 2.3, 9.4, 0.6, barrel_h),
        _square("barrel_5", "barrel", 3.5, 9.4, 0.6, barrel_h),
        # Power distribution: panels 1.0 wide x 0.4 deep, backs on the north wall.
        Box("panel_1", 7.3, 9.4, 8.3, 9.8, 2.0, "panel"),
        Box("panel_2", 8.5, 9.4, 9.5, 9.8, 2.0, "panel"),
        Box("panel_3", 9.7, 9.4, 10.7, 9.8, 2.0, "panel"),
        # Plumbing: the column carrying the overhead exhaust pipe.
        _square("pipe_support", "pipe_support", 16.8, 8.5, 0.3, _WALL_HEIGHT),
    )
    rooms = (
        Room("corridor", "Corridor", 0.0, 0.0, _WIDTH, _CORRIDOR_Y),
        Room("chemical_storage", "Chemical storage", 0.0, _CORRIDOR_Y, _DIVIDERS_X[0], _DEPTH),
        Room("power_distribution", "Power distribution", _DIVIDERS_X[0], _CORRIDOR_Y, _DIVIDERS_X[1], _DEPTH),
        Room("plumbing", "Plumbing", _DIVIDERS_X[1], _CORRIDOR_Y, _WIDTH, _DEPTH),
    )
    spawns = tuple(Spawn(f"robot{i + 1}", x, 1.5, math.pi / 2) for i, x in enumerate(_DOOR_CENTRES_X))
    # The spill runs from under the leaking barrel (1.0, 8.9) out into the room
    # towards the gas source, so a robot at the door sees it in front of the
    # barrel; the ellipse's long axis points from the barrel to (1.8, 8.2).
    spill_axis = math.atan2(8.2 - 8.9, 1.8 - 1.0)
    decals = (
        Decal("spill", "spill", 1.65, 8.35, 0.95, 0.6, spill_axis),
        Decal("puddle", "puddle", 15.6, 7.6, 0.7, 0.5, 0.3),
    )
    # The exhaust pipe spans the plumbing room wall to wall just below the
    # ceiling line of the walls; the column at (16.8, 8.5) carries it via a bracket.
    pipes = (Pipe("pipe", _DIVIDERS_X[1] + 0.5 * _WALL, _WIDTH - _WALL, 7.6, 2.2, 0.12, 15.6),)
    # Sources of the sensor fields; robots.yaml's sim.hazards repeats them.
    hazards = (
        HazardSource("gas", 1.8, 8.2, 800.0, 1.5),  # the spill under the leaking barrel
        HazardSource("temperature", 7.8, 9.6, 6.0, 1.2),  # electrical panels: warm, not hot
        HazardSource("temperature", 9.0, 9.6, 6.0, 1.2),
        HazardSource("temperature", 10.2, 9.6, 6.0, 1.2),
        HazardSource("humidity", 15.6, 7.6, 45.0, 1.8),  # leaking exhaust pipe over a puddle
    )
    return FloorPlan(_WIDTH, _DEPTH, _WALL, walls, obstacles, rooms, spawns, doors, decals, pipes, hazards)


def rasterise(plan: FloorPlan, resolution: float = 0.05) -> OccupancyGrid:
    """Rasterise ``plan`` into a grid covering ``[0, width] x [0, depth]``.

    A cell is occupied when its centre lies inside (or on the edge of) any
    wall or obstacle box; doors and floor markings stay free. The origin is
    (0, 0). ``resolution`` must be positive; the cell count is rounded up so
    the whole building is covered.
    """
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise ValueError(f"resolution must be a positive finite number, got {resolution!r}")
    # Round before ceil so 18 / 0.05 = 359.99999999999994 gives 360, not 361.
    cols = math.ceil(round(plan.width / resolution, 9))
    rows = math.ceil(round(plan.depth / resolution, 9))
    occupied = np.zeros((rows, cols), dtype=np.bool_)
    eps = 1e-9
    for box in plan.solids:
        # Index range of cell centres (i + 0.5) * res inside [min, max]:
        # one slice assignment per box instead of a per-cell test.
        c0 = max(math.ceil(box.min_x / resolution - 0.5 - eps), 0)
        c1 = min(math.floor(box.max_x / resolution - 0.5 + eps), cols - 1)
        r0 = max(math.ceil(box.min_y / resolution - 0.5 - eps), 0)
        r1 = min(math.floor(box.max_y / resolution - 0.5 + eps), rows - 1)
        # A box thinner than a cell may contain no centre at all; keep it
        # solid anyway (the cell under its middle) so coarse rasters never
        # open holes in walls.
        cx, cy = box.centre
        if c0 > c1:
            c0 = c1 = min(max(math.floor(cx / resolution), 0), cols - 1)
        if r0 > r1:
            r0 = r1 = min(max(math.floor(cy / resolution), 0), rows - 1)
        occupied[r0 : r1 + 1, c0 : c1 + 1] = True
    return OccupancyGrid(0.0, 0.0, resolution, occupied)
