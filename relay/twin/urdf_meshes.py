"""The geometry of robot models from URDF (relay.twin.urdf's half that deals in triangles): boxes, cylinders
and spheres, mesh files (STL, COLLADA) found through ROS package paths, simplification to a triangle budget,
and crease-aware normals.
"""

from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final
from urllib.parse import unquote, urlsplit

import numpy as np
import trimesh
from numpy.typing import NDArray

from relay.errors import RelayError

logger = logging.getLogger(__name__)

PackagePaths = Mapping[str, Path] | Sequence[Path]

#: Adjacent faces meeting at a sharper angle than this (degrees) get separate normals.
CREASE_ANGLE_DEG: Final = 35.0
#: Mesh files larger than this are not read (a robot's description must not make the relay load gigabytes).
MAX_MESH_FILE_BYTES: Final = 64 * 1024 * 1024
# Facets of generated cylinders: enough to look round at arm's length in a headset.
_CYLINDER_SECTIONS: Final = 32
_SPHERE_SUBDIVISIONS: Final = 2


class RobotModelError(RelayError):
    """A URDF cannot be turned into a model: unparsable XML, no links, a broken tree, or (with
    ``fallback=False``) a mesh file that is missing or unreadable. The message says which."""


class _MeshUnavailable(Exception):
    """A mesh URI that cannot be turned into triangles; the message names the file and why."""


@dataclass
class _Geometry:
    """Triangles in some frame (ROS axes, metres). ``smooth``: emit crease-aware normals (primitives);
    otherwise none, and the client shades the triangles flat (mesh files)."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    smooth: bool = True

    def transformed(self, matrix: NDArray[np.float64]) -> _Geometry:
        vertices = self.vertices @ matrix[:3, :3].T + matrix[:3, 3]
        faces = self.faces
        if np.linalg.det(matrix[:3, :3]) < 0:
            # A mirroring scale turns triangles inside out; reverse their winding to keep them front-facing.
            faces = faces[:, ::-1].copy()
        return _Geometry(vertices, faces, self.smooth)


def _as_geometry(mesh: Any) -> _Geometry:
    return _Geometry(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64))


def _box(size: Sequence[float] | NDArray[np.float64]) -> _Geometry:
    return _as_geometry(trimesh.creation.box(extents=[float(s) for s in size]))


def _primitive(geometry: Any) -> _Geometry:
    """A URDF box, cylinder (along z, centred) or sphere as triangles in its own frame."""
    if geometry.box is not None:
        return _box(np.asarray(geometry.box.size, dtype=np.float64).reshape(3))
    if geometry.cylinder is not None:
        return _as_geometry(
            trimesh.creation.cylinder(
                radius=float(geometry.cylinder.radius),
                height=float(geometry.cylinder.length),
                sections=_CYLINDER_SECTIONS,
            )
        )
    if geometry.sphere is not None:
        return _as_geometry(
            trimesh.creation.icosphere(subdivisions=_SPHERE_SUBDIVISIONS, radius=float(geometry.sphere.radius))
        )
    raise RobotModelError("a <geometry> without box, cylinder, sphere or mesh")


def _load_mesh(uri: str, scale: Any, resolver: _MeshResolver) -> _Geometry:
    """The mesh file behind ``uri`` as flat-shaded triangles in metres (COLLADA unit and ``<mesh scale>``
    applied). Raises :class:`_MeshUnavailable` naming the file when it is missing, too big or unreadable."""
    path = resolver.resolve(uri)
    if path is None:
        raise _MeshUnavailable(f"mesh {uri} not found{resolver.where()}")
    try:
        size = path.stat().st_size
        if size > MAX_MESH_FILE_BYTES:
            raise _MeshUnavailable(f"mesh {uri} is {size} bytes, over the {MAX_MESH_FILE_BYTES} byte limit")
        # force="mesh" flattens multi-part files (COLLADA scenes) with their node transforms applied.
        loaded = trimesh.load(str(path), force="mesh")
        unit = _collada_unit(path) if path.suffix.lower() == ".dae" else 1.0
    except _MeshUnavailable:
        raise
    except Exception as err:  # trimesh and its format plug-ins raise anything from KeyError to XML errors
        raise _MeshUnavailable(f"mesh {uri} ({path}) cannot be read: {type(err).__name__}: {err}") from err
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise _MeshUnavailable(f"mesh {uri} ({path}) has no triangles")
    # process=True merges duplicate vertices (STL stores three per triangle): a third of the size, and the
    # simplifier needs shared vertices to see which triangles touch.
    mesh = _as_geometry(trimesh.Trimesh(vertices=loaded.vertices, faces=loaded.faces, process=True))
    mesh.smooth = False
    factors = np.full(3, unit)
    if scale is not None:
        factors *= np.broadcast_to(np.asarray(scale, dtype=np.float64).reshape(-1), (3,))
    if not np.all(np.isfinite(factors)) or np.any(factors == 0):
        raise _MeshUnavailable(f"mesh {uri} has an unusable scale {factors.tolist()}")
    return mesh.transformed(np.diag([*factors, 1.0]))


def _collada_unit(path: Path) -> float:
    """The ``<asset><unit meter="...">`` of a COLLADA file, 1.0 when absent."""
    for _, element in ET.iterparse(path, events=("start",)):
        tag = element.tag.rsplit("}", 1)[-1]
        if tag == "unit":
            try:
                return float(element.get("meter", "1"))
            except ValueError:
                return 1.0
        if tag.startswith("library_"):
            break  # <asset> comes first; no unit there means metres
    return 1.0


def _simplify(mesh: _Geometry, max_triangles: int) -> _Geometry:
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
    return _Geometry(vertices, faces, mesh.smooth)


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


def _crease_normals(
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


def _drop_degenerate(
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


def _concatenate(geometries: Sequence[_Geometry]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    offsets = np.cumsum([0] + [len(g.vertices) for g in geometries[:-1]])
    vertices = np.concatenate([g.vertices for g in geometries], axis=0)
    faces = np.concatenate([g.faces + offset for g, offset in zip(geometries, offsets, strict=True)], axis=0)
    return vertices, faces


class _MeshResolver:
    """Maps URDF mesh URIs to files under the package paths (see :func:`urdf_to_glb`)."""

    def __init__(self, package_paths: PackagePaths, *, confine: bool) -> None:
        self._named: dict[str, Path] = {}
        self._dirs: list[Path] = []
        if isinstance(package_paths, Mapping):
            self._named = {name: Path(path) for name, path in package_paths.items()}
        else:
            self._dirs = [Path(path) for path in package_paths]
        self._confine = confine
        self._roots = [p.resolve() for p in [*self._named.values(), *self._dirs]]
        self._package_names: dict[Path, str | None] = {}
        self._children: dict[Path, list[Path]] = {}

    def where(self) -> str:
        count = len(self._named) + len(self._dirs)
        return f" (searched {count} package path{'s' if count != 1 else ''})" if count else " (no package paths)"

    def resolve(self, uri: str) -> Path | None:
        """The first existing regular file ``uri`` can mean, or None."""
        for candidate, root in self._candidates(uri):
            try:
                real = candidate.resolve()
            except (OSError, RuntimeError):
                continue
            if root is not None and not real.is_relative_to(root.resolve()):
                continue  # `package://pkg/../../etc/x` must not leave the package
            if self._confine and not any(real.is_relative_to(r) for r in self._roots):
                continue
            if real.is_file():
                return real
        return None

    def _candidates(self, uri: str) -> Iterator[tuple[Path, Path | None]]:
        parts = urlsplit(uri)
        scheme = parts.scheme.lower()
        if scheme == "package":
            package, relative = parts.netloc, unquote(parts.path).lstrip("/")
            for directory in self._package_dirs(package):
                yield directory / relative, directory
        elif scheme == "file":
            yield Path(unquote(parts.path)), None
        elif scheme == "":
            path = Path(uri)
            if path.is_absolute():
                yield path, None
            else:
                for directory in [*self._named.values(), *self._dirs]:
                    yield directory / path, directory
        # Other schemes (http, model, ...) name nothing we can read.

    def _package_dirs(self, package: str) -> Iterator[Path]:
        if package in self._named:
            yield self._named[package]
        for directory in self._dirs:
            if directory.name == package or self._package_name(directory) == package:
                yield directory
            yield directory / package
            # A folder of packages whose directory names differ from their manifest names (src/ layouts).
            for sub in self._subpackages(directory):
                if sub.name != package and self._package_name(sub) == package:
                    yield sub

    def _subpackages(self, directory: Path) -> list[Path]:
        if directory not in self._children:
            try:
                found = sorted(d for d in directory.iterdir() if (d / "package.xml").is_file())
            except OSError:
                found = []
            self._children[directory] = found
        return self._children[directory]

    def _package_name(self, directory: Path) -> str | None:
        if directory not in self._package_names:
            name: str | None = None
            manifest = directory / "package.xml"
            try:
                name = ET.parse(manifest).getroot().findtext("name")
            except (OSError, ET.ParseError):
                name = None
            self._package_names[directory] = name.strip() if name else None
        return self._package_names[directory]
