"""Normals of a robot model's triangles: crease-aware for primitives, none for mesh files.

Boxes, cylinders and spheres get per-vertex normals split at creases sharper than :data:`CREASE_ANGLE_DEG`,
so boxes stay crisp and cylinders round. Mesh files keep their exact triangles and get no normals: glTF
clients then shade them flat (the specification requires it), which is how RViz shows STL facets and halves
the size; they only lose the triangles that float32 leaves without an area.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import NDArray

#: Adjacent faces meeting at a sharper angle than this (degrees) get separate normals.
CREASE_ANGLE_DEG: Final = 35.0


def crease_normals(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], crease_angle_deg: float
) -> tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.int64]]:
    """Per-vertex normals that are smooth across gentle edges and split at sharp ones.

    Each triangle corner gets the area-weighted mean normal of the triangles around its vertex that face
    within ``crease_angle_deg`` of its own triangle; corners of one vertex with the same normal share an
    output vertex. Degenerate (zero-area) triangles are dropped: they have no normal. Returns float32
    positions, unit float32 normals and the triangle indices into them.
    """
    corners = vertices[faces]
    raw = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # length = 2 x area
    length = np.linalg.norm(raw, axis=1)
    keep = length > 1e-14
    faces, raw, length = faces[keep], raw[keep], length[keep]
    unit = raw / length[:, None]
    n_faces = len(faces)

    corner_vertex = faces.reshape(-1)
    corner_face = np.repeat(np.arange(n_faces), 3)
    by_vertex = np.argsort(corner_vertex, kind="stable")
    faces_by_vertex = corner_face[by_vertex]
    degree = np.bincount(corner_vertex, minlength=len(vertices))
    start = np.concatenate(([0], np.cumsum(degree)[:-1]))
    # Every (corner, triangle sharing the corner's vertex) pair.
    pair_degree = degree[corner_vertex]
    pair_corner = np.repeat(np.arange(3 * n_faces), pair_degree)
    offset = np.arange(len(pair_corner)) - np.repeat(np.cumsum(pair_degree) - pair_degree, pair_degree)
    pair_face = faces_by_vertex[start[corner_vertex][pair_corner] + offset]
    cos_limit = math.cos(math.radians(crease_angle_deg))
    smooth = np.einsum("ij,ij->i", unit[corner_face[pair_corner]], unit[pair_face]) >= cos_limit
    summed = np.stack(
        [
            np.bincount(pair_corner[smooth], weights=raw[pair_face[smooth], axis], minlength=3 * n_faces)
            for axis in range(3)
        ],
        axis=1,
    )
    normals = summed / np.linalg.norm(summed, axis=1)[:, None]  # each corner counts its own face: never zero

    # Corners of one vertex whose normals agree to ~0.06 degrees become one output vertex.
    quantised = np.round(normals * 1000.0).astype(np.int64)
    key = np.concatenate([corner_vertex[:, None], quantised], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    out_positions = vertices[corner_vertex[first]].astype(np.float32)
    out_normals = normals[first]
    out_normals = (out_normals / np.linalg.norm(out_normals, axis=1)[:, None]).astype(np.float32)
    return out_positions, out_normals, inverse.reshape(-1, 3).astype(np.int64)


def drop_degenerate(
    vertices: NDArray[np.float64], faces: NDArray[np.int64]
) -> tuple[NDArray[np.float32], NDArray[np.int64]]:
    """float32 positions and the triangles that still have an area in float32 (a flat-shaded triangle
    without area has no normal; the validator flags it), with unused vertices removed."""
    positions = vertices.astype(np.float32)
    corners = positions.astype(np.float64)[faces]
    area2 = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    faces = faces[area2 > 1e-14]
    used, remap = np.unique(faces.reshape(-1), return_inverse=True)
    return positions[used], remap.reshape(-1, 3).astype(np.int64)
