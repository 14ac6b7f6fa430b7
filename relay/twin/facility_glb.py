"""The demo floor plan as a glTF scene (``scenes/facility.glb``): corridor, rooms, barrels, panels, the pipe, the
spill and the puddle, each a node named as in the floor plan (relay/twin/facility.py writes the scene file beside it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..fleet.geometry import yaw_to_quaternion
from ..sim.floorplan import EDGE_SEGMENTS, Box, Decal, FloorPlan, Pipe, edge_radius
from .gltf import Geometry, Material, Mesh, Node, Primitive, build_glb, merge
from .shapes import box, cylinder, polygon, sphere

__all__ = ["facility_glb"]

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


def _blob(decal: Decal, segments: int = EDGE_SEGMENTS) -> NDArray[np.float64]:
    """Outline of a decal relative to its centre: the ellipse with a roughened (liquid-looking) edge.

    The wobble is a fixed sum of sines (no randomness) bounded by +-23 %, inside the 1.25x the floor plan
    allows, and the radius stays positive so the outline is star-shaped around the centre.
    """
    c, s = math.cos(decal.angle), math.sin(decal.angle)
    points = []
    for i in range(segments):
        t = math.tau * i / segments
        r = edge_radius(t)
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
