"""Mesh files of a URDF: finding them through ROS package paths, and reading them (STL, COLLADA) as triangles.

A mesh URI is ``package://pkg/path``, ``file://path``, an absolute path, or a path relative to one of the
package paths. The resolver never lets ``..`` leave a package, and when ``confine`` is set (descriptions
from the network) it reads nothing outside the given paths at all.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, Final
from urllib.parse import unquote, urlsplit

import numpy as np
import trimesh

from .errors import MeshUnavailable
from .primitives import Triangles

PackagePaths = Mapping[str, Path] | Sequence[Path]

#: Mesh files larger than this are not read (a robot's description must not make the relay load gigabytes).
MAX_MESH_FILE_BYTES: Final = 64 * 1024 * 1024


def load_mesh(uri: str, scale: Any, resolver: MeshResolver) -> Triangles:
    """The mesh file behind ``uri`` as flat-shaded triangles in metres (COLLADA unit and ``<mesh scale>``
    applied). Raises :class:`MeshUnavailable` naming the file when it is missing, too big or unreadable."""
    path = resolver.resolve(uri)
    if path is None:
        raise MeshUnavailable(f"mesh {uri} not found{resolver.where()}")
    try:
        size = path.stat().st_size
        if size > MAX_MESH_FILE_BYTES:
            raise MeshUnavailable(f"mesh {uri} is {size} bytes, over the {MAX_MESH_FILE_BYTES} byte limit")
        # force="mesh" flattens multi-part files (COLLADA scenes) with their node transforms applied.
        loaded = trimesh.load(str(path), force="mesh")
        unit = _collada_unit(path) if path.suffix.lower() == ".dae" else 1.0
    except MeshUnavailable:
        raise
    except Exception as err:  # trimesh and its format plug-ins raise anything from KeyError to XML errors
        raise MeshUnavailable(f"mesh {uri} ({path}) cannot be read: {type(err).__name__}: {err}") from err
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshUnavailable(f"mesh {uri} ({path}) has no triangles")
    # process=True merges duplicate vertices (STL stores three per triangle): a third of the size, and the
    # simplifier needs shared vertices to see which triangles touch.
    mesh = Triangles.of_trimesh(trimesh.Trimesh(vertices=loaded.vertices, faces=loaded.faces, process=True))
    mesh.smooth = False
    factors = np.full(3, unit)
    if scale is not None:
        factors *= np.broadcast_to(np.asarray(scale, dtype=np.float64).reshape(-1), (3,))
    if not np.all(np.isfinite(factors)) or np.any(factors == 0):
        raise MeshUnavailable(f"mesh {uri} has an unusable scale {factors.tolist()}")
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


class MeshResolver:
    """Maps URDF mesh URIs to files under the package paths (see :func:`relay.twin.urdf.urdf_to_glb`).

    With ``confine`` it returns only files inside those paths (what a description from the network may read).
    """

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
        """`` (searched N package paths)``, to end a "not found" message."""
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
