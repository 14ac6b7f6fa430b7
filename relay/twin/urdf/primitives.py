"""Triangles in a link's frame, and the URDF's primitive shapes (box, cylinder, sphere) built as triangles.

Every shape of a robot model, primitive or mesh file, is a :class:`Triangles` until the glTF assembly
(:mod:`relay.twin.urdf.assembly`) gives it normals or none. Visuals and the collision geometry that stands in
for a missing mesh are built by the one :func:`primitive`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import trimesh
from numpy.typing import NDArray

from .errors import RobotModelError

# Facets of generated cylinders: enough to look round at arm's length in a headset.
_CYLINDER_SECTIONS: Final = 32
_SPHERE_SUBDIVISIONS: Final = 2
_KINDS: Final = ("box", "cylinder", "sphere")


@dataclass
class Triangles:
    """Triangles in some frame (ROS axes, metres). ``smooth``: emit crease-aware normals (primitives);
    otherwise none, and the client shades the triangles flat (mesh files)."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    smooth: bool = True

    @classmethod
    def of_trimesh(cls, mesh: Any, *, smooth: bool = True) -> Triangles:
        """The vertices and faces of a ``trimesh.Trimesh`` (its normals are not used)."""
        return cls(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64), smooth)

    def transformed(self, matrix: NDArray[np.float64]) -> Triangles:
        """A copy with ``matrix`` (4 x 4, affine) applied to the vertices."""
        vertices = self.vertices @ matrix[:3, :3].T + matrix[:3, 3]
        faces = self.faces
        if np.linalg.det(matrix[:3, :3]) < 0:
            # A mirroring scale turns triangles inside out; reverse their winding to keep them front-facing.
            faces = faces[:, ::-1].copy()
        return Triangles(vertices, faces, self.smooth)


def box(size: Sequence[float] | NDArray[np.float64]) -> Triangles:
    """A box of edge lengths ``size`` (x, y, z), centred on the origin."""
    return Triangles.of_trimesh(trimesh.creation.box(extents=[float(s) for s in size]))


def primitive(geometry: Any) -> Triangles:
    """A URDF box, cylinder (along z, centred) or sphere (a yourdfpy ``Geometry``) as triangles in its own
    frame; :class:`RobotModelError` for a geometry that is none of them nor a mesh."""
    if geometry.box is not None:
        return box(np.asarray(geometry.box.size, dtype=np.float64).reshape(3))
    if geometry.cylinder is not None:
        return Triangles.of_trimesh(
            trimesh.creation.cylinder(
                radius=float(geometry.cylinder.radius),
                height=float(geometry.cylinder.length),
                sections=_CYLINDER_SECTIONS,
            )
        )
    if geometry.sphere is not None:
        return Triangles.of_trimesh(
            trimesh.creation.icosphere(subdivisions=_SPHERE_SUBDIVISIONS, radius=float(geometry.sphere.radius))
        )
    raise RobotModelError("a <geometry> without box, cylinder, sphere or mesh")


def primitive_kind(geometry: Any) -> str:
    """``box``, ``cylinder`` or ``sphere``: which primitive a URDF geometry (without a mesh) is, for warnings."""
    return next(kind for kind in _KINDS if getattr(geometry, kind) is not None)


def concatenate(parts: Sequence[Triangles]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The vertices and faces of ``parts`` as one triangle list (indices shifted; nothing merged)."""
    offsets = np.cumsum([0] + [len(g.vertices) for g in parts[:-1]])
    vertices = np.concatenate([g.vertices for g in parts], axis=0)
    faces = np.concatenate([g.faces + offset for g, offset in zip(parts, offsets, strict=True)], axis=0)
    return vertices, faces
