"""The facility twin: the demo floor plan as a glTF scene plus the scene file the simulator reads.

``tools/build_scene.py`` writes both from :func:`relay.sim.floorplan.demo_facility` (the single source of
truth for the geometry):

* ``scenes/facility.glb`` (:func:`facility_glb`): corridor, three rooms with door openings, barrels (one
  leaking over a spill), electrical panels, the overhead exhaust pipe dripping into a puddle. Glb node names
  equal the floor plan's names (``floor``, ``wall_north``, ``barrel_leaking``, ``panel_1``, ``spill``,
  ``puddle``, ``pipe``, ...); glTF Y-up via :mod:`relay.twin.frames`, map frame = scene frame.
* ``scenes/facility.yaml`` (:func:`facility_yaml`): hazards, spawns, rooms, the occupancy grid rasterised
  from the walls and obstacles, and the glb's file name. :func:`load_facility` reads it back, validating
  every field. The file documents its own format in its header comment.

Both outputs are deterministic (same input, same bytes), so the committed files can be compared with a
fresh build.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from relay.geometry import yaw_to_quaternion
from relay.occupancy import OccupancyGrid, read_yaml
from relay.sim.floorplan import Box, Decal, FloorPlan, Pipe, Room, Spawn, rasterise, room_named, spawn_of
from relay.sim.hazards import HazardSource

from .gltf import Geometry, Material, Mesh, Node, Primitive, box, build_glb, cylinder, merge, polygon, sphere

__all__ = [
    "FORMAT",
    "GRID_ENCODING",
    "Facility",
    "decode_rows",
    "encode_rows",
    "facility_glb",
    "facility_yaml",
    "load_facility",
]

#: Value of the ``format`` field; bump the suffix on an incompatible change.
FORMAT = "xr-relay-facility/1"
#: Value of ``grid.encoding``: see :func:`encode_rows`.
GRID_ENCODING = "rle-rows"

# -- materials (linear RGB, as glTF specifies; the client renders in sRGB) ----------------------------------
# The spill's yellow-green appears nowhere else, so a camera image can find it by colour; the panels'
# yellow is kept well apart in hue (about 44 vs 83 degrees after sRGB encoding).
_FLOOR = Material("floor_concrete", (0.35, 0.35, 0.36, 1.0), metallic=0.0, roughness=0.9)
_WALL = Material("wall_beige", (0.78, 0.70, 0.56, 1.0), metallic=0.0, roughness=0.9)
_BARREL = Material("barrel_steel", (0.30, 0.34, 0.38, 1.0), metallic=0.5, roughness=0.5)
_RUST = Material("rust", (0.45, 0.15, 0.04, 1.0), metallic=0.3, roughness=0.8)
_SPILL = Material("spill_chemical", (0.30, 0.90, 0.0, 1.0), metallic=0.0, roughness=0.25)
_WATER = Material("water", (0.03, 0.25, 0.85, 1.0), metallic=0.0, roughness=0.1)
_PANEL = Material("panel_grey", (0.50, 0.52, 0.55, 1.0), metallic=0.6, roughness=0.45)
_WARNING = Material("warning_yellow", (1.0, 0.5, 0.0, 1.0), metallic=0.0, roughness=0.6)
_BLACK = Material("warning_black", (0.02, 0.02, 0.02, 1.0), metallic=0.0, roughness=0.6)
_PIPE = Material("pipe_galvanised", (0.62, 0.63, 0.65, 1.0), metallic=0.9, roughness=0.35)
_STEEL = Material("steel_dark", (0.25, 0.25, 0.27, 1.0), metallic=0.7, roughness=0.5)

# Floor markings float this far above the floor: enough to avoid z-fighting at room scale in a 24-bit
# depth buffer, too little to see.
_DECAL_Z = 0.004
_BARREL_SEGMENTS = 24


# ---------------------------------------------------------------------------------------------------------
# glb


def _blob(decal: Decal, segments: int = 48) -> NDArray[np.float64]:
    """Outline of a decal relative to its centre: the ellipse with a roughened (liquid-looking) edge.

    The wobble is a fixed sum of sines (no randomness) bounded by +-23 %, inside the 1.25x the floor plan
    allows, and the radius stays positive so the outline is star-shaped around the centre.
    """
    c, s = math.cos(decal.angle), math.sin(decal.angle)
    points = []
    for i in range(segments):
        t = math.tau * i / segments
        r = 1.0 + 0.12 * math.sin(3 * t + 0.7) + 0.07 * math.sin(5 * t + 2.1) + 0.04 * math.sin(8 * t + 0.3)
        u, v = decal.radius_x * r * math.cos(t), decal.radius_y * r * math.sin(t)
        points.append((c * u - s * v, s * u + c * v))
    return np.array(points)


def _decal_node(decal: Decal, material: Material) -> Node:
    geom = polygon(_blob(decal), _DECAL_Z, centre=(0.0, 0.0))
    return Node(
        decal.name, Mesh(decal.name, (Primitive(geom, material),)), (decal.x, decal.y, 0.0), extras={"kind": decal.kind}
    )


def _box_geometry(b: Box) -> Geometry:
    """A floor-standing box of the plan; its bottom face is never visible, so it is left out."""
    return box((b.min_x, b.min_y, 0.0), (b.max_x, b.max_y, b.height), bottom=False)


def _barrel_geometry(radius: float, height: float) -> Geometry:
    """A drum: body plus two rolling hoops, standing on z = 0 around the origin."""
    parts = [cylinder(radius, (0.0, 0.0, 0.0), (0.0, 0.0, height), segments=_BARREL_SEGMENTS, caps=(False, True))]
    for z in (height / 3.0, 2.0 * height / 3.0):
        hoop = cylinder(radius + 0.012, (0.0, 0.0, z - 0.015), (0.0, 0.0, z + 0.015), segments=_BARREL_SEGMENTS)
        parts.append(hoop)
    return merge(parts)


def _quad(corners: Sequence[tuple[float, float, float]], normal: tuple[float, float, float]) -> Geometry:
    """A flat quad from four corners listed counter-clockwise as seen from the side ``normal`` faces."""
    return Geometry(np.array(corners), np.repeat([normal], 4, axis=0), np.array([[0, 1, 2], [0, 2, 3]]))


def _panel_mesh(width: float, depth: float, height: float) -> Mesh:
    """An electrical cabinet centred on the origin whose front faces -y (into the room, away from the wall).

    Grey body, a yellow front door and a band of black diagonal hazard stripes near its top.
    """
    hw, hd = 0.5 * width, 0.5 * depth
    body = box((-hw, -hd, 0.0), (hw, hd, height), bottom=False)
    door_w, door_z0, door_z1 = hw - 0.05, 0.15, height - 0.15
    door = box((-door_w, -hd - 0.012, door_z0), (door_w, -hd, door_z1), bottom=True)
    y = -hd - 0.014  # stripes 2 mm in front of the door
    band_z0, band_z1 = door_z1 - 0.35, door_z1 - 0.1
    slant = band_z1 - band_z0  # 45 degree stripes
    stripes = []
    for x0 in (-door_w + 0.03, -door_w + 0.28, -door_w + 0.53):
        x1 = x0 + 0.1
        stripes.append(
            _quad(
                [(x0, y, band_z0), (x1, y, band_z0), (x1 + slant, y, band_z1), (x0 + slant, y, band_z1)],
                (0.0, -1.0, 0.0),
            )
        )
    return Mesh(
        "panel",
        (Primitive(body, _PANEL), Primitive(door, _WARNING), Primitive(merge(stripes), _BLACK)),
    )


def _pipe_nodes(pipe: Pipe, support: Box | None) -> list[Node]:
    """The pipe (anchored at its middle), its leak point and, if present, the support column with a bracket."""
    mid = 0.5 * (pipe.x0 + pipe.x1)
    half = 0.5 * (pipe.x1 - pipe.x0)
    tube = cylinder(pipe.radius, (-half, 0.0, 0.0), (half, 0.0, 0.0), segments=24, caps=(False, False))
    nodes = [
        Node(pipe.name, Mesh(pipe.name, (Primitive(tube, _PIPE),)), (mid, pipe.y, pipe.z), extras={"kind": "pipe"})
    ]

    # The leak: a corroded collar and water drops falling towards the puddle below it.
    collar = cylinder(pipe.radius + 0.015, (-0.06, 0.0, 0.0), (0.06, 0.0, 0.0), segments=24)
    drops = merge(sphere(0.025, (0.0, 0.0, -dz), segments=10, rings=6) for dz in (0.22, 0.6, 1.05, 1.55))
    leak = Mesh(f"{pipe.name}_leak", (Primitive(collar, _RUST), Primitive(drops, _WATER)))
    nodes.append(Node(f"{pipe.name}_leak", leak, (pipe.leak_x, pipe.y, pipe.z), extras={"kind": "leak"}))

    if support is not None:
        cx, cy = support.centre
        column = _box_geometry(support)
        # A bracket from the column to the pipe at pipe height and a clamp around the pipe.
        toward = -1.0 if pipe.y < cy else 1.0
        near_y = support.min_y if toward < 0 else support.max_y
        y0, y1 = sorted((near_y, pipe.y))
        bracket = box((cx - 0.04, y0, pipe.z - 0.04), (cx + 0.04, y1, pipe.z + 0.04))
        clamp = cylinder(pipe.radius + 0.02, (cx - 0.03, pipe.y, pipe.z), (cx + 0.03, pipe.y, pipe.z), segments=24)
        geom = merge([column, bracket, clamp]).translated(-cx, -cy, 0.0)
        nodes.append(
            Node(
                support.name,
                Mesh(support.name, (Primitive(geom, _STEEL),)),
                (cx, cy, 0.0),
                extras={"kind": support.kind},
            )
        )
    return nodes


def facility_glb(plan: FloorPlan) -> bytes:
    """The glTF (GLB) twin of ``plan``, deterministic, Y-up, map frame = scene frame.

    Nodes (all at the top level, names from the plan): ``floor`` (one quad over ``[0, width] x [0, depth]``
    at z = 0, the client's raycast target), ``wall_south`` / ``wall_north`` / ``wall_west`` / ``wall_east``,
    ``walls_interior`` (corridor wall runs, dividers and door lintels merged into one mesh), one node per
    obstacle (barrels as drums, panels as cabinets, the pipe support), one per decal (``spill``, ``puddle``),
    and per pipe ``<name>`` and ``<name>_leak``. Semantic nodes are translated to their anchor (footprint
    centre on the floor, pipe axis midpoint, leak point) so a client can aim a camera at them. Every node
    carries ``extras.kind``.
    """
    nodes: list[Node] = []
    floor = _quad(
        [(0.0, 0.0, 0.0), (plan.width, 0.0, 0.0), (plan.width, plan.depth, 0.0), (0.0, plan.depth, 0.0)],
        (0.0, 0.0, 1.0),
    )
    nodes.append(Node("floor", Mesh("floor", (Primitive(floor, _FLOOR),)), extras={"kind": "floor"}))

    outer = {"wall_south", "wall_north", "wall_west", "wall_east"}
    for wall in plan.walls:
        if wall.name in outer:
            mesh = Mesh(wall.name, (Primitive(_box_geometry(wall), _WALL),))
            nodes.append(Node(wall.name, mesh, extras={"kind": "wall"}))
    interior = [_box_geometry(w) for w in plan.walls if w.name not in outer]
    # Lintels close the wall above each door opening up to the height of the walls beside it.
    wall_height = max(w.height for w in plan.walls)
    interior += [
        box((d.min_x, d.min_y, d.height), (d.max_x, d.max_y, wall_height), bottom=True)
        for d in plan.doors
        if d.height < wall_height
    ]
    if interior:
        mesh = Mesh("walls_interior", (Primitive(merge(interior), _WALL),))
        nodes.append(Node("walls_interior", mesh, extras={"kind": "wall"}))

    # Shared meshes: every plain barrel is one instance of the same drum; the leaking one reuses its
    # geometry (same accessors) with the rust material; the three panels share one cabinet.
    barrel_meshes: dict[tuple[float, float, bool], Mesh] = {}
    barrel_geoms: dict[tuple[float, float], Geometry] = {}
    panel_meshes: dict[tuple[float, float, float], Mesh] = {}
    support: Box | None = None
    for obstacle in plan.obstacles:
        cx, cy = obstacle.centre
        sx, sy = obstacle.max_x - obstacle.min_x, obstacle.max_y - obstacle.min_y
        if obstacle.kind == "barrel":
            # The drum is inscribed in its square footprint, hoops included.
            radius = 0.5 * min(sx, sy) - 0.015
            gkey = (round(radius, 6), round(obstacle.height, 6))
            if gkey not in barrel_geoms:
                barrel_geoms[gkey] = _barrel_geometry(radius, obstacle.height)
            leaking = "leaking" in obstacle.name
            mkey = (*gkey, leaking)
            if mkey not in barrel_meshes:
                name = "barrel_leaking" if leaking else "barrel"
                barrel_meshes[mkey] = Mesh(name, (Primitive(barrel_geoms[gkey], _RUST if leaking else _BARREL),))
            mesh = barrel_meshes[mkey]
            nodes.append(Node(obstacle.name, mesh, (cx, cy, 0.0), extras={"kind": obstacle.kind}))
        elif obstacle.kind == "panel":
            pkey = (round(sx, 6), round(sy, 6), round(obstacle.height, 6))
            if pkey not in panel_meshes:
                panel_meshes[pkey] = _panel_mesh(sx, sy, obstacle.height)
            # Cabinets stand with their back to the nearer horizontal wall, front facing into the room.
            yaw = 0.0 if cy > 0.5 * plan.depth else math.pi
            nodes.append(
                Node(obstacle.name, panel_meshes[pkey], (cx, cy, 0.0), yaw_to_quaternion(yaw), extras={"kind": "panel"})
            )
        elif obstacle.kind == "pipe_support" and plan.pipes:
            support = obstacle  # drawn with its pipe, below
        else:
            mesh = Mesh(obstacle.name, (Primitive(_box_geometry(obstacle).translated(-cx, -cy, 0.0), _STEEL),))
            nodes.append(Node(obstacle.name, mesh, (cx, cy, 0.0), extras={"kind": obstacle.kind}))

    for decal in plan.decals:
        nodes.append(_decal_node(decal, _SPILL if decal.kind == "spill" else _WATER))
    for index, pipe in enumerate(plan.pipes):
        nodes.extend(_pipe_nodes(pipe, support if index == 0 else None))
    return build_glb(nodes, scene_name="facility")


# ---------------------------------------------------------------------------------------------------------
# facility.yaml


def encode_rows(occupied: NDArray[np.bool_]) -> list[str]:
    """Run-length encode a boolean grid row by row (``rle-rows``).

    Each row becomes a string of space-separated run lengths that alternate free, occupied, free, ...
    starting with a free run (``0`` when the row starts occupied) and summing to the width; rows are listed
    from row 0 (lowest y, ROS order) upwards. Plain integers, unlike a zlib stream, encode identically with
    every library version, so the committed file can be compared byte for byte.
    """
    rows = []
    for row in np.asarray(occupied, dtype=np.bool_):
        padded = np.concatenate(([False], row, [not row[-1]]))
        edges = np.flatnonzero(padded[1:] != padded[:-1])
        # edges are the indices where the value flips; the first run is free (possibly empty).
        runs = np.diff(np.concatenate(([0], edges)))
        rows.append(" ".join(str(int(n)) for n in runs))
    return rows


def decode_rows(rows: Sequence[str], width: int, height: int, where: str = "rows") -> NDArray[np.bool_]:
    """Inverse of :func:`encode_rows`; ``ValueError`` mentioning ``where`` for a malformed row."""
    if len(rows) != height:
        raise ValueError(f"{where}: expected {height} rows, got {len(rows)}")
    out = np.zeros((height, width), dtype=np.bool_)
    for r, text in enumerate(rows):
        if not isinstance(text, str):
            raise ValueError(f"{where}[{r}]: expected a string of run lengths, got {text!r}")
        try:
            runs = [int(tok) for tok in text.split()]
        except ValueError:
            raise ValueError(f"{where}[{r}]: run lengths must be integers, got {text!r}") from None
        if not runs or min(runs) < 0 or sum(runs) != width:
            raise ValueError(f"{where}[{r}]: run lengths must be >= 0 and sum to the width {width}, got {text!r}")
        col = 0
        for k, n in enumerate(runs):
            if k % 2:
                out[r, col : col + n] = True
            col += n
    return out


def _num(value: float) -> str:
    """Stable YAML number: Python's shortest round-trip repr, ``-0.0`` normalised."""
    return repr(float(value) + 0.0)


def _str(value: str) -> str:
    # JSON strings are valid YAML flow scalars, and json.dumps quotes deterministically.
    return json.dumps(value, ensure_ascii=False)


def _header(resolution: float) -> list[str]:
    return [
        "# The demo facility for the simulator. Generated by tools/build_scene.py from",
        "# relay.sim.floorplan.demo_facility(): do not edit by hand, regenerate (a test compares them).",
        "#",
        "# Coordinates are the map frame (REP 103: x east, y north, metres; yaw in rad, CCW from +x). The map",
        "# frame is the scene frame of the glb (scene.glb), which is glTF Y-up: glTF (x, y, z) = (x, z, -y).",
        "#",
        "# hazards: sources of the simulated sensor fields, value = peak * exp(-d^2 / (2 sigma^2)) added to the",
        "#   field's baseline (robots.yaml sim.fields) at distance d metres.",
        "# spawns:  initial robot poses.   rooms: name, title shown to operators, bounds (walls included).",
        f"# grid:    occupancy rasterised from the walls and obstacles at {resolution:g} m: a cell is occupied",
        "#   when its centre lies inside a solid box. origin = lower-left corner of cell (row 0, col 0).",
        "#   encoding rle-rows: rows[r] is row r (row 0 = lowest y, as nav_msgs/OccupancyGrid), a string of",
        "#   space-separated run lengths alternating free, occupied, free, ... starting with a free run (0 when",
        "#   the row starts occupied), summing to width.",
    ]


def facility_yaml(plan: FloorPlan, resolution: float = 0.05, glb: str = "facility.glb") -> str:
    """The scene file of ``plan`` (see the header it writes for the format); deterministic text."""
    grid = rasterise(plan, resolution)
    lines = [*_header(resolution), f"format: {FORMAT}", f"scene: {{glb: {_str(glb)}, up: Y}}"]
    lines.append(f"size: {{width: {_num(plan.width)}, depth: {_num(plan.depth)}}}")
    lines.append("hazards:")
    for h in plan.hazards:
        fields = f"x: {_num(h.x)}, y: {_num(h.y)}, peak: {_num(h.peak)}, sigma: {_num(h.sigma)}"
        lines.append(f"  - {{kind: {_str(h.kind)}, {fields}}}")
    lines.append("spawns:")
    for s in plan.spawns:
        lines.append(f"  - {{robot: {_str(s.robot)}, x: {_num(s.x)}, y: {_num(s.y)}, yaw: {_num(s.yaw)}}}")
    lines.append("rooms:")
    for room in plan.rooms:
        bounds = (
            f"{{min_x: {_num(room.min_x)}, min_y: {_num(room.min_y)}, "
            f"max_x: {_num(room.max_x)}, max_y: {_num(room.max_y)}}}"
        )
        lines.append(f"  - {{name: {_str(room.name)}, title: {_str(room.title)}, bounds: {bounds}}}")
    lines += [
        "grid:",
        f"  origin: {{x: {_num(grid.origin_x)}, y: {_num(grid.origin_y)}}}",
        f"  resolution: {_num(grid.resolution)}",
        f"  width: {grid.width}",
        f"  height: {grid.height}",
        f"  encoding: {GRID_ENCODING}",
        "  rows:",
    ]
    lines += [f'    - "{row}"' for row in encode_rows(grid.occupied)]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Facility:
    """A loaded scene file: everything the simulator needs from the scene.

    ``glb`` is the scene's glTF file resolved against the yaml's directory (it need not exist for the
    simulator); ``up`` is its up axis (always ``"Y"``). ``size`` is ``(width, depth)`` of the building.
    """

    source: Path
    grid: OccupancyGrid
    hazards: tuple[HazardSource, ...]
    spawns: tuple[Spawn, ...]
    rooms: tuple[Room, ...]
    glb: Path
    up: str
    size: tuple[float, float]

    def spawn(self, robot: str) -> Spawn:
        """The spawn of ``robot``; ``KeyError`` if there is none."""
        return spawn_of(self.spawns, robot, f" in {self.source}")

    def room(self, name: str) -> Room:
        """The room called ``name``; ``KeyError`` if there is none."""
        return room_named(self.rooms, name, f" in {self.source}")


class _Fields:
    """Typed access to a parsed YAML tree with errors naming the file and the field path."""

    def __init__(self, source: Path) -> None:
        self.source = source

    def fail(self, where: str, expected: str, got: object) -> ValueError:
        return ValueError(f"{self.source}: field '{where}' must be {expected}, got {got!r}")

    def mapping(self, node: object, where: str, keys: Sequence[str]) -> dict[str, Any]:
        if not isinstance(node, dict):
            raise self.fail(where or "(top level)", "a mapping", node)
        prefix = f"{where}." if where else ""
        unknown = sorted(str(k) for k in node if k not in keys)
        if unknown:
            raise ValueError(f"{self.source}: unknown field '{prefix}{unknown[0]}' (expected one of {list(keys)})")
        missing = [k for k in keys if k not in node]
        if missing:
            raise ValueError(f"{self.source}: missing field '{prefix}{missing[0]}'")
        return node

    def sequence(self, node: object, where: str) -> list[Any]:
        if not isinstance(node, list):
            raise self.fail(where, "a list", node)
        return node

    def number(self, node: object, where: str, *, positive: bool = False) -> float:
        if isinstance(node, bool) or not isinstance(node, (int, float)) or not math.isfinite(node):
            raise self.fail(where, "a finite number", node)
        if positive and node <= 0:
            raise self.fail(where, "a positive number", node)
        return float(node)

    def integer(self, node: object, where: str) -> int:
        if isinstance(node, bool) or not isinstance(node, int) or node < 1:
            raise self.fail(where, "a positive integer", node)
        return node

    def string(self, node: object, where: str) -> str:
        if not isinstance(node, str) or not node:
            raise self.fail(where, "a non-empty string", node)
        return node


def _hazards(f: _Fields, node: Any) -> list[HazardSource]:
    hazards = []
    for i, item in enumerate(f.sequence(node, "hazards")):
        where = f"hazards[{i}]"
        h = f.mapping(item, where, ("kind", "x", "y", "peak", "sigma"))
        hazards.append(
            HazardSource(
                kind=f.string(h["kind"], f"{where}.kind"),
                x=f.number(h["x"], f"{where}.x"),
                y=f.number(h["y"], f"{where}.y"),
                peak=f.number(h["peak"], f"{where}.peak"),
                sigma=f.number(h["sigma"], f"{where}.sigma", positive=True),
            )
        )
    return hazards


def _spawns(f: _Fields, node: Any, source: Path) -> list[Spawn]:
    spawns = []
    for i, item in enumerate(f.sequence(node, "spawns")):
        where = f"spawns[{i}]"
        s = f.mapping(item, where, ("robot", "x", "y", "yaw"))
        spawns.append(
            Spawn(
                f.string(s["robot"], f"{where}.robot"),
                f.number(s["x"], f"{where}.x"),
                f.number(s["y"], f"{where}.y"),
                f.number(s["yaw"], f"{where}.yaw"),
            )
        )
    if len({s.robot for s in spawns}) != len(spawns):
        raise ValueError(f"{source}: field 'spawns' names a robot twice")
    return spawns


def _rooms(f: _Fields, node: Any, source: Path) -> list[Room]:
    rooms = []
    for i, item in enumerate(f.sequence(node, "rooms")):
        where = f"rooms[{i}]"
        r = f.mapping(item, where, ("name", "title", "bounds"))
        b = f.mapping(r["bounds"], f"{where}.bounds", ("min_x", "min_y", "max_x", "max_y"))
        lo_x, lo_y, hi_x, hi_y = (f.number(b[k], f"{where}.bounds.{k}") for k in ("min_x", "min_y", "max_x", "max_y"))
        if not (lo_x < hi_x and lo_y < hi_y):
            raise f.fail(f"{where}.bounds", "non-empty (min < max)", b)
        rooms.append(
            Room(f.string(r["name"], f"{where}.name"), f.string(r["title"], f"{where}.title"), lo_x, lo_y, hi_x, hi_y)
        )
    if len({r.name for r in rooms}) != len(rooms):
        raise ValueError(f"{source}: field 'rooms' names a room twice")
    return rooms


def load_facility(path: str | os.PathLike[str]) -> Facility:
    """Read and validate a facility scene file written by :func:`facility_yaml`.

    Raises:
        ValueError: naming the file and the field (e.g. ``grid.rows[12]``) when the file is missing,
            unreadable, not YAML, or any field is absent, unknown, of the wrong type or inconsistent
            (wrong ``format`` or ``encoding``, a room with empty bounds, rows that do not match the size).
    """
    source = Path(path)
    doc = read_yaml(source, "facility file")
    f = _Fields(source)
    top = f.mapping(doc, "", ("format", "scene", "size", "hazards", "spawns", "rooms", "grid"))
    if top["format"] != FORMAT:
        raise f.fail("format", repr(FORMAT), top["format"])

    scene = f.mapping(top["scene"], "scene", ("glb", "up"))
    glb = f.string(scene["glb"], "scene.glb")
    if scene["up"] != "Y":
        raise f.fail("scene.up", "'Y' (glTF is Y-up)", scene["up"])
    size_node = f.mapping(top["size"], "size", ("width", "depth"))
    size = (
        f.number(size_node["width"], "size.width", positive=True),
        f.number(size_node["depth"], "size.depth", positive=True),
    )

    hazards = _hazards(f, top["hazards"])
    spawns = _spawns(f, top["spawns"], source)
    rooms = _rooms(f, top["rooms"], source)

    g = f.mapping(top["grid"], "grid", ("origin", "resolution", "width", "height", "encoding", "rows"))
    origin = f.mapping(g["origin"], "grid.origin", ("x", "y"))
    if g["encoding"] != GRID_ENCODING:
        raise f.fail("grid.encoding", repr(GRID_ENCODING), g["encoding"])
    width = f.integer(g["width"], "grid.width")
    height = f.integer(g["height"], "grid.height")
    rows = f.sequence(g["rows"], "grid.rows")
    try:
        occupied = decode_rows(rows, width, height, where="grid.rows")
    except ValueError as exc:
        raise ValueError(f"{source}: field {exc}") from None
    grid = OccupancyGrid(
        f.number(origin["x"], "grid.origin.x"),
        f.number(origin["y"], "grid.origin.y"),
        f.number(g["resolution"], "grid.resolution", positive=True),
        occupied,
    )
    for spawn in spawns:
        if not grid.is_free(spawn.x, spawn.y):
            raise ValueError(
                f"{source}: spawn of {spawn.robot} at ({spawn.x}, {spawn.y}) is not on a free cell of the grid"
            )
    return Facility(source, grid, tuple(hazards), tuple(spawns), tuple(rooms), source.parent / glb, "Y", size)
