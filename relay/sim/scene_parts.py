"""A glTF scene flattened into map-frame parts with their faces' base colours: what the simulated cameras cast rays
into (relay/sim/camera.py). The scene is converted to ROS Z-up once (:data:`relay.twin.frames.GLTF_TO_ROS`); colours
are linear, as glTF specifies them, textures decoded from sRGB.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from ..twin.frames import GLTF_TO_ROS

__all__ = ["DEFAULT_ALBEDO", "ScenePart", "face_albedo", "parts_from_scene"]

#: Colour of faces without any colour information (linear): trimesh's default grey.
DEFAULT_ALBEDO = (0.4, 0.4, 0.4)


def _srgb_to_linear(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Decode sRGB in [0, 1] (texture images are sRGB-encoded in glTF) to linear."""
    out: NDArray[np.float64] = np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)
    return out


@dataclass(frozen=True)
class ScenePart:
    """One piece of geometry of the scene, already in the map frame (ROS, Z-up, metres).

    ``path`` names the scene nodes from the root down to this geometry (e.g. ``("panel_1", "panel_1_front")``),
    ``faces`` index ``vertices``, and ``albedo`` is each face's linear RGB base colour in [0, 1] (shape
    ``(len(faces), 3)``).
    """

    path: tuple[str, ...]
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    albedo: NDArray[np.float64]


def parts_from_scene(
    scene: trimesh.Scene | trimesh.Trimesh, *, y_up: bool = True, map_to_scene: ArrayLike | None = None
) -> list[ScenePart]:
    """Flatten a trimesh scene into map-frame :class:`ScenePart` s with per-face linear base colours.

    Every geometry instance of the scene graph becomes a part (its world transform applied); meshes without
    triangles (paths, point clouds) are skipped. ``y_up``: the scene is glTF (Y-up) and is converted to ROS
    (Z-up) with ``GLTF_TO_ROS``. ``map_to_scene`` (4x4, ROS conventions, None = identity) is where the map
    frame sits in the scene; its inverse brings the scene into the map frame.
    """
    if isinstance(scene, trimesh.Trimesh):
        scene = trimesh.Scene(scene)
    to_ros = GLTF_TO_ROS if y_up else np.eye(4)
    if map_to_scene is not None:
        to_ros = np.linalg.inv(np.asarray(map_to_scene, dtype=np.float64).reshape(4, 4)) @ to_ros
    parents = scene.graph.transforms.parents
    base = scene.graph.base_frame
    parts: list[ScenePart] = []
    for node in scene.graph.nodes_geometry:
        transform, geometry_name = scene.graph[node]
        geometry = scene.geometry.get(geometry_name)
        if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
            continue
        path: list[str] = []
        current = node
        while current != base and current is not None:
            path.append(str(current))
            current = parents.get(current)
        vertices = trimesh.transform_points(np.asarray(geometry.vertices, dtype=np.float64), to_ros @ transform)
        parts.append(
            ScenePart(
                path=tuple(reversed(path)),
                vertices=vertices,
                faces=np.asarray(geometry.faces, dtype=np.int64),
                albedo=face_albedo(geometry),
            )
        )
    return parts


def face_albedo(geometry: trimesh.Trimesh) -> NDArray[np.float64]:
    """Linear RGB base colour of each face, ``(F, 3)`` in [0, 1].

    A material's colour wins (PBR ``baseColorFactor``, times the mean of its base colour texture when it has
    one, decoded from sRGB; a simple material's diffuse colour likewise); otherwise the geometry's face
    colours (glTF vertex colours are linear too); otherwise :data:`DEFAULT_ALBEDO`.
    """
    count = len(geometry.faces)
    visual = geometry.visual
    material = getattr(visual, "material", None)
    colour: NDArray[np.float64] | None = None
    if isinstance(material, trimesh.visual.material.PBRMaterial):
        factor = material.baseColorFactor
        colour = np.ones(3) if factor is None else np.asarray(factor, dtype=np.float64)[:3] / 255.0
        colour = colour * _texture_mean(material.baseColorTexture)
    elif isinstance(material, trimesh.visual.material.SimpleMaterial):
        colour = np.asarray(material.diffuse, dtype=np.float64)[:3] / 255.0 * _texture_mean(material.image)
    elif material is not None:
        colour = np.asarray(material.main_color, dtype=np.float64)[:3] / 255.0
    if colour is not None:
        return np.tile(colour, (count, 1))
    if isinstance(visual, trimesh.visual.ColorVisuals) and visual.kind is not None:
        return np.asarray(visual.face_colors, dtype=np.float64)[:, :3] / 255.0
    return np.tile(np.asarray(DEFAULT_ALBEDO, dtype=np.float64), (count, 1))


def _texture_mean(image: Any) -> NDArray[np.float64]:
    """Mean linear RGB of a PIL image (sRGB-encoded, as glTF base colour textures are), or white for None."""
    if image is None:
        return np.ones(3)
    pixels = np.asarray(image.convert("RGB"), dtype=np.float64).reshape(-1, 3) / 255.0
    out: NDArray[np.float64] = _srgb_to_linear(pixels).mean(axis=0)
    return out
