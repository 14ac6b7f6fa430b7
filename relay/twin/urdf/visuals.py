"""A link's visuals as coloured triangles in the link's frame, with the fallback for mesh files that fail.

A mesh file that is missing or unreadable never aborts the conversion (unless ``fallback=False``): the
link's collision geometry stands in for it (boxes, cylinders, spheres, or a collision mesh that loads), else
a :data:`FALLBACK_BOX_SIZE` cube at the visual's origin, and a warning names the file.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from ..gltf import Material
from .errors import MeshUnavailable, RobotModelError
from .materials import visual_material
from .meshes import MeshResolver, load_mesh
from .primitives import Triangles, box, primitive, primitive_kind

#: Edge of the cube drawn for a missing mesh when the link has no usable collision geometry (metres).
FALLBACK_BOX_SIZE: Final = 0.05

Part = tuple[Material, Triangles]


def link_parts(
    link: Any,
    is_body: bool,
    urdf_colours: Mapping[str, Any],
    resolver: MeshResolver,
    fallback: bool,
    warnings: list[str],
) -> list[Part]:
    """The visuals of yourdfpy ``link`` with their materials (see :func:`visual_material`), in URDF order.

    Appends a warning for every visual skipped or replaced; with ``fallback=False`` a mesh file that cannot
    be used raises :class:`RobotModelError` instead.
    """
    parts: list[Part] = []
    used_collision_fallback = False
    for visual in link.visuals:
        material = visual_material(link.name, visual, is_body, urdf_colours)
        origin = _origin(visual)
        geometry = visual.geometry
        if geometry is None:
            warnings.append(f"link {link.name}: a <visual> has no geometry; skipped")
            continue
        if geometry.mesh is None:
            parts.append((material, primitive(geometry).transformed(origin)))
            continue
        try:
            mesh = load_mesh(geometry.mesh.filename, geometry.mesh.scale, resolver)
        except MeshUnavailable as err:
            if not fallback:
                raise RobotModelError(f"link {link.name}: {err}") from err
            if used_collision_fallback:
                # The link's collision geometry already stands in for it once; drawing it twice adds nothing.
                warnings.append(f"link {link.name}: {err}; covered by the collision geometry drawn already")
                continue
            stand_ins, what, from_collision = _fallback_geometry(link, origin, resolver)
            used_collision_fallback = from_collision
            warnings.append(f"link {link.name}: {err}; drew {what} instead")
            parts.extend((material, stand_in) for stand_in in stand_ins)
            continue
        parts.append((material, mesh.transformed(origin)))
    return parts


def _origin(element: Any) -> NDArray[np.float64]:
    """The pose of a ``<visual>`` or ``<collision>`` in its link's frame (identity when it has none)."""
    return np.eye(4) if element.origin is None else np.asarray(element.origin, dtype=np.float64)


def _fallback_geometry(
    link: Any, visual_origin: NDArray[np.float64], resolver: MeshResolver
) -> tuple[list[Triangles], str, bool]:
    """Stand-ins for a missing visual mesh: the link's collision geometry, else a small box at the visual's
    origin. Returns them, a description for the warning, and whether they came from the collisions."""
    stand_ins: list[Triangles] = []
    kinds: list[str] = []
    for collision in link.collisions:
        geometry = collision.geometry
        if geometry is None:
            continue
        origin = _origin(collision)
        if geometry.mesh is None:
            stand_ins.append(primitive(geometry).transformed(origin))
            kinds.append(primitive_kind(geometry))
            continue
        try:
            stand_ins.append(load_mesh(geometry.mesh.filename, geometry.mesh.scale, resolver).transformed(origin))
            kinds.append("mesh")
        except MeshUnavailable:
            continue
    if stand_ins:
        return stand_ins, "its collision geometry (" + ", ".join(kinds) + ")", True
    stand_in = box((FALLBACK_BOX_SIZE,) * 3).transformed(visual_origin)
    return [stand_in], f"a {FALLBACK_BOX_SIZE * 100:g} cm box", False
