"""Fitting a robot's mesh files into a triangle budget: vertex clustering with quadric placement.

A detailed CAD export (hundreds of thousands of triangles) would not load on a headset; clustering is
deterministic, and good at what such exports overdo (dense fillets, threads, tiny holes) at sizes seen from
a metre away.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import NDArray

from .primitives import Triangles
from .tree import LinkNode, walk

logger = logging.getLogger(__name__)


def apply_triangle_budget(root: LinkNode, budget: int) -> None:
    """Simplify the mesh-file geometry of the model in place when it holds more than ``budget`` triangles:
    each mesh gets a share proportional to its triangle count. Primitives are small and stay as they are."""
    meshes = [(node, i) for node in walk(root) for i, (_, g) in enumerate(node.parts) if not g.smooth]
    total = sum(len(node.parts[i][1].faces) for node, i in meshes)
    if total <= budget:
        return
    for node, i in meshes:
        material, geometry = node.parts[i]
        share = max(1, budget * len(geometry.faces) // total)
        node.parts[i] = (material, simplify(geometry, share))
    logger.debug("simplified %d mesh triangles to a budget of %d", total, budget)


def simplify(mesh: Triangles, max_triangles: int) -> Triangles:
    """Vertex clustering: snap vertices to a grid, merge each cell's vertices (see :func:`_cluster`) and
    drop the triangles that collapse. Coarsens the grid until at most ``max_triangles`` remain.
    Deterministic, and good at what CAD exports overdo (dense fillets, threads, tiny holes) at sizes seen
    from a metre away."""
    if len(mesh.faces) <= max_triangles:
        return mesh
    corners = mesh.vertices[mesh.faces]
    area = 0.5 * float(
        np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1).sum()
    )
    extent = float(np.max(np.ptp(mesh.vertices, axis=0)))
    # A clustered surface keeps roughly two triangles per occupied cell of its area: start a little finer
    # than that estimate and coarsen in small steps, so the result lands just under the budget.
    cell = max(0.5 * math.sqrt(2.0 * area / max_triangles), extent * 1e-4, 1e-9)
    vertices, faces = mesh.vertices, mesh.faces
    for _ in range(60):
        vertices, faces = _cluster(mesh.vertices, mesh.faces, cell)
        if len(faces) <= max_triangles:
            break
        cell *= 1.15
    return Triangles(vertices, faces, mesh.smooth)


def _cluster(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], cell: float
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    grid = np.floor((vertices - vertices.min(axis=0)) / cell).astype(np.int64)
    dims = grid.max(axis=0) + 1
    keys = (grid[:, 0] * dims[1] + grid[:, 1]) * dims[2] + grid[:, 2]
    # Vertices facing opposite ways never merge: the top and bottom of a plate thinner than a cell would
    # otherwise collapse into one crumpled sheet. The facing is the dominant axis of the vertex normal.
    keys = keys * 6 + _facing(vertices, faces)
    _, cluster = np.unique(keys, return_inverse=True)
    cluster = cluster.reshape(-1)
    merged = _cluster_positions(vertices, faces, cluster, cell)
    new_faces = cluster[faces]
    keep = (
        (new_faces[:, 0] != new_faces[:, 1])
        & (new_faces[:, 1] != new_faces[:, 2])
        & (new_faces[:, 0] != new_faces[:, 2])
    )
    new_faces = new_faces[keep]
    # Clustering folds distinct triangles onto the same three vertices; keep the first of each.
    _, first = np.unique(np.sort(new_faces, axis=1), axis=0, return_index=True)
    new_faces = new_faces[np.sort(first)]
    used, remap = np.unique(new_faces.reshape(-1), return_inverse=True)
    return merged[used], remap.reshape(-1, 3).astype(np.int64)


def _facing(vertices: NDArray[np.float64], faces: NDArray[np.int64]) -> NDArray[np.int64]:
    """0..5 per vertex: which of +x, -x, +y, -y, +z, -z its area-weighted normal is closest to."""
    corners = vertices[faces]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    summed = np.stack(
        [np.bincount(faces.reshape(-1), weights=np.repeat(normal[:, k], 3), minlength=len(vertices)) for k in range(3)],
        1,
    )
    axis = np.argmax(np.abs(summed), axis=1)
    negative = summed[np.arange(len(vertices)), axis] < 0
    facing: NDArray[np.int64] = (axis * 2 + negative).astype(np.int64)
    return facing


def _cluster_positions(
    vertices: NDArray[np.float64], faces: NDArray[np.int64], cluster: NDArray[np.int64], cell: float
) -> NDArray[np.float64]:
    """Where each cluster's merged vertex goes: the point closest (in the least-squares sense) to the
    planes of the triangles around it, as in Lindstrom's out-of-core simplification. A plain mean would
    pull vertices off flat plates and round every edge; the quadric keeps plates flat and edges sharp."""
    n_clusters = int(cluster.max()) + 1
    counts = np.bincount(cluster, minlength=n_clusters).astype(np.float64)
    sums = np.stack([np.bincount(cluster, weights=vertices[:, i], minlength=n_clusters) for i in range(3)], 1)
    mean: NDArray[np.float64] = sums / counts[:, None]

    corners = vertices[faces]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])  # length = 2 x area
    area2 = np.linalg.norm(normal, axis=1)
    valid = area2 > 0
    unit = np.zeros_like(normal)
    unit[valid] = normal[valid] / area2[valid, None]
    offset = np.einsum("ij,ij->i", unit, corners[:, 0])
    # Area-weighted plane quadrics: A = sum(w n n^T), b = sum(w n d); each triangle counts for its corners.
    outer = (area2[:, None, None] * unit[:, :, None] * unit[:, None, :]).reshape(-1, 9)
    rhs = area2[:, None] * unit * offset[:, None]
    owner = cluster[faces].reshape(-1)
    quad_a = np.stack(
        [np.bincount(owner, weights=np.repeat(outer[:, k], 3), minlength=n_clusters) for k in range(9)], 1
    ).reshape(-1, 3, 3)
    quad_b = np.stack([np.bincount(owner, weights=np.repeat(rhs[:, k], 3), minlength=n_clusters) for k in range(3)], 1)
    # A small pull towards the mean fixes the directions the planes leave free (along a plate, an edge).
    regulariser = 1e-3 * np.trace(quad_a, axis1=1, axis2=2) + 1e-30
    eye = np.eye(3)[None, :, :]
    solved = np.linalg.solve(
        quad_a + regulariser[:, None, None] * eye, (quad_b + regulariser[:, None] * mean)[:, :, None]
    )[:, :, 0]
    # Nearly parallel planes can put the optimum far away; such clusters keep their mean.
    stray = np.linalg.norm(solved - mean, axis=1) > cell
    solved[stray] = mean[stray]
    return solved
