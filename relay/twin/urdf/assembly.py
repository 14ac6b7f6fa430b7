"""A robot's kinematic tree as glTF, through the one glTF writer (:mod:`relay.twin.gltf`).

Each link becomes a node named after it, holding one mesh of one primitive per (material, smooth or flat)
in first-use order; the writer turns ROS axes into glTF's Y-up frame, so vertices and node transforms come
out converted and no node carries the axis swap as a rotation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..gltf import Geometry, Material, Mesh, Node, Primitive, build_glb
from .materials import unique_name
from .normals import CREASE_ANGLE_DEG, crease_normals, drop_degenerate
from .primitives import Triangles, concatenate
from .tree import ROOT_NODE, LinkNode


def encode_glb(root: LinkNode) -> bytes:
    """The model through the one glTF writer (relay.twin.gltf), ROS frame in, glTF's Y-up frame out."""
    return build_glb([_gltf_node(root, {})], scene_name=ROOT_NODE)


def _gltf_node(node: LinkNode, names: dict[str, Material]) -> Node:
    """A link as a glTF node: one mesh of a primitive per (material, smooth or flat), in first-use order.

    ``names`` keeps material names unique across the model (see :func:`unique_name`).
    """
    groups: dict[tuple[Material, bool], list[Triangles]] = {}
    for material, geometry in node.parts:
        groups.setdefault((material, geometry.smooth), []).append(geometry)
    primitives: list[Primitive] = []
    for (material, smooth), geometries in groups.items():
        triangles = _geometry(geometries, smooth)
        if triangles is not None:
            primitives.append(Primitive(triangles, unique_name(material, names)))
    matrix = node.matrix
    return Node(
        node.name,
        mesh=Mesh(node.name, tuple(primitives)) if primitives else None,
        translation=(float(matrix[0, 3]), float(matrix[1, 3]), float(matrix[2, 3])),
        rotation=_quaternion(matrix),
        children=tuple(_gltf_node(child, names) for child in node.children),
        extras=dict(node.extras) if node.extras else None,
    )


def _geometry(parts: list[Triangles], smooth: bool) -> Geometry | None:
    """``parts`` as one glTF geometry, with crease-aware normals when ``smooth``, else none; None when no
    triangle with an area is left."""
    vertices, faces = concatenate(parts)
    if smooth:
        positions, normals, indices = crease_normals(vertices, faces, CREASE_ANGLE_DEG)
    else:
        positions, indices = drop_degenerate(vertices, faces)
        normals = None
    if len(indices) == 0:
        return None
    normals64 = None if normals is None else _settled(normals)
    return Geometry(_settled(positions), normals64, indices)


def _settled(values: NDArray[Any]) -> NDArray[np.float64]:
    """Values to a nanometre (and -0.0 as 0.0): numpy builds differ in the last bits of sums (values of 1e-16 where
    another build gives 0 were seen in the committed model), and the model is committed as bytes."""
    settled: NDArray[np.float64] = np.asarray(values, dtype=np.float64).round(9)
    settled += 0.0
    return settled


def _quaternion(matrix: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """Unit quaternion ``(x, y, z, w)`` with ``w >= 0`` of the rotation part of ``matrix`` (Shepperd's
    method, on plain floats: no eigen-solver whose last bits could vary between machines)."""
    r = [[float(v) for v in row] for row in matrix[:3, :3]]
    trace = r[0][0] + r[1][1] + r[2][2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        x, y, z, w = (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, 0.25 * s
    else:
        # The largest diagonal element picks the axis i (j, k follow it cyclically): no division by ~0.
        i = 0 if r[0][0] > r[1][1] and r[0][0] > r[2][2] else 1 if r[1][1] > r[2][2] else 2
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + r[i][i] - r[j][j] - r[k][k])
        q = [0.0, 0.0, 0.0]
        q[i], q[j], q[k] = 0.25 * s, (r[i][j] + r[j][i]) / s, (r[i][k] + r[k][i]) / s
        x, y, z, w = q[0], q[1], q[2], (r[k][j] - r[j][k]) / s
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    sign = -1.0 if w < 0.0 else 1.0  # q and -q are one rotation: w >= 0 keeps the output canonical
    return (sign * x / norm, sign * y / norm, sign * z / norm, sign * w / norm)
