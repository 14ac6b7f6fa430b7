"""Robot models for the twin: a URDF (a file, or a robot's ``/robot_description``) becomes one GLB.

What the produced glTF promises (the client and the relay rely on it):

* Metres, glTF Y-up, robot forward along glTF ``+x`` (ROS ``+x``). The one ROS → glTF conversion is
  :data:`relay.twin.frames.ROS_TO_GLTF`; it is baked into vertices and node transforms, never left as a
  rotation on a node, so the client can overwrite the root's transform freely.
* Node 0 is ``robot``, the scene's only root, with an identity transform, at the robot's reference frame:
  ``base_footprint`` when the URDF has one, else ``base_link``, else the URDF's root link. Setting the
  ``robot`` node to the pose of that frame (``odom -> base_footprint``, converted to glTF) places the model.
* Under it, one node per URDF link, named exactly after the link (namespace included), nested as in the
  kinematic tree and posed for the zero joint configuration (yourdfpy's forward kinematics). A link's
  visuals (meshes, boxes, cylinders, spheres) form one glTF mesh named after the link, in the link's own
  frame, so turning a wheel node about its joint axis spins the wheel.
* Materials, all metallic-roughness with metallic 0:

  - ``body`` (:data:`BODY_MATERIAL`): neutral light grey, used by the chassis (the first link with visuals,
    walking the tree breadth-first from the root: normally ``base_link``) whatever colour the URDF gives
    it. **It is the tintable material**: the client replaces or multiplies its ``baseColorFactor`` with
    the robot's colour; no other material is meant to be tinted.
  - ``tyre`` (:data:`TYRE_MATERIAL`): near-black rubber, every link whose name mentions a wheel, tyre,
    tire, caster or track, so wheels read as wheels on any tint.
  - any other link: its URDF ``<material>`` colour, as a material named after the URDF material (URDF
    colours are the sRGB values RViz shows; they are converted to glTF's linear ``baseColorFactor``), or
    ``part`` (:data:`PART_MATERIAL`, mid grey) when the URDF gives none. Textures are not carried over.
* A mesh file that is missing or unreadable never aborts the conversion (unless ``fallback=False``): the
  link's collision geometry stands in for it (boxes, cylinders, spheres, or a collision mesh that loads),
  else a :data:`FALLBACK_BOX_SIZE` cube at the visual's origin, and the returned warnings name the file.
* STL files carry no unit: the URDF ``<mesh scale>`` is applied as given (TurtleBot3's millimetre STLs
  say ``scale="0.001 0.001 0.001"``). COLLADA files are scaled by their ``<unit meter>`` first, as RViz
  does, then by ``<mesh scale>``.
* Mesh files keep their exact triangles and get no ``NORMAL`` attribute: glTF clients then shade them flat
  (the specification requires it), which is how RViz shows STL facets and halves the size. Boxes,
  cylinders and spheres carry normals split at creases sharper than :data:`CREASE_ANGLE_DEG`, so boxes
  stay crisp and cylinders round. When a robot's mesh files hold more than :data:`MODEL_TRIANGLE_BUDGET`
  triangles, each is simplified by vertex clustering to its share of the budget, so a detailed CAD export
  still loads on a headset (the TurtleBot3 Waffle Pi, 121 k triangles, needs none: 1.4 MB).
* Deterministic: the same URDF text and mesh files give the same bytes.

Untrusted descriptions: :func:`robot_description_glb` (what the relay calls with a robot's
``/robot_description``) only reads mesh files inside the given search paths, and falls back to
:func:`procedural_robot_glb` instead of raising. External XML entities are not resolved (lxml >= 5 default).
"""

from __future__ import annotations

import io
import json
import logging
import math
import re
import struct
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final
from urllib.parse import unquote, urlsplit

import numpy as np
import trimesh
import yourdfpy  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import NDArray

from relay.errors import RelayError
from relay.twin.frames import ROS_TO_GLTF

logger = logging.getLogger(__name__)

#: Name of the tintable chassis material (see the module docstring).
BODY_MATERIAL: Final = "body"
#: Name of the dark material of wheels, tyres, casters and tracks.
TYRE_MATERIAL: Final = "tyre"
#: Name of the default material of links without a URDF colour.
PART_MATERIAL: Final = "part"
#: Name of the root node; the client poses the robot through it.
ROOT_NODE: Final = "robot"

#: Most triangles the mesh files of one robot may keep; over it, each is simplified to its share.
MODEL_TRIANGLE_BUDGET: Final = 150_000
#: Adjacent faces meeting at a sharper angle than this (degrees) get separate normals.
CREASE_ANGLE_DEG: Final = 35.0
#: Edge of the cube drawn for a missing mesh when the link has no usable collision geometry (metres).
FALLBACK_BOX_SIZE: Final = 0.05
#: Mesh files larger than this are not read (a robot's description must not make the relay load gigabytes).
MAX_MESH_FILE_BYTES: Final = 64 * 1024 * 1024

# Facets of generated cylinders: enough to look round at arm's length in a headset.
_CYLINDER_SECTIONS: Final = 32
_SPHERE_SUBDIVISIONS: Final = 2
_WHEEL_NAME = re.compile(r"wheel|tyre|tire|caster|track", re.IGNORECASE)
_NAMESPACE_PLACEHOLDER = re.compile(r"\$\{\s*namespace\s*\}")
_RESERVED_MATERIALS: Final = frozenset({BODY_MATERIAL, TYRE_MATERIAL, PART_MATERIAL})

# The 3x3 rotation part of ROS_TO_GLTF, for directions and vertices.
_R: Final[NDArray[np.float64]] = ROS_TO_GLTF[:3, :3]

PackagePaths = Mapping[str, Path] | Sequence[Path]


class RobotModelError(RelayError):
    """A URDF cannot be turned into a model: unparsable XML, no links, a broken tree, or (with
    ``fallback=False``) a mesh file that is missing or unreadable. The message says which."""


@dataclass(frozen=True)
class _Material:
    """A glTF metallic-roughness material; ``rgba`` is linear, as glTF's ``baseColorFactor``."""

    name: str
    rgba: tuple[float, float, float, float]
    roughness: float


BODY: Final = _Material(BODY_MATERIAL, (0.7, 0.7, 0.7, 1.0), 0.6)
TYRE: Final = _Material(TYRE_MATERIAL, (0.02, 0.02, 0.02, 1.0), 0.9)
PART: Final = _Material(PART_MATERIAL, (0.214, 0.214, 0.214, 1.0), 0.7)


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


@dataclass
class _Node:
    """A link: its transform relative to the parent node (ROS axes), geometry in its frame, children."""

    name: str
    matrix: NDArray[np.float64]
    parts: list[tuple[_Material, _Geometry]] = field(default_factory=list)
    children: list[_Node] = field(default_factory=list)
    extras: dict[str, str] = field(default_factory=dict)


# --------------------------------------------------------------------------------------------- public API


def substitute_namespace(urdf_text: str, namespace: str = "") -> str:
    """``urdf_text`` with every ``${namespace}`` placeholder replaced by ``namespace`` verbatim.

    TurtleBot3's URDFs write frame names as ``${namespace}base_link``, so pass ``"tb3_0/"`` (with its slash)
    to get ``tb3_0/base_link``; the default ``""`` strips the placeholders.
    """
    return _NAMESPACE_PLACEHOLDER.sub(lambda _: namespace, urdf_text)


def urdf_to_glb(
    urdf_text: str,
    package_paths: PackagePaths,
    *,
    namespace: str = "",
    fallback: bool = True,
) -> tuple[bytes, list[str]]:
    """Convert a URDF document into GLB bytes and a list of human-readable warnings.

    ``package_paths`` resolves mesh URIs: a mapping from ROS package name to the package's directory, or a
    sequence of directories that are either packages themselves (matched by directory name or by the
    ``<name>`` in their ``package.xml``) or folders holding packages. ``package://pkg/x`` is looked up
    there, ``file://`` and absolute paths are read as they are, relative paths are tried under each
    directory. ``${namespace}`` placeholders are substituted with ``namespace`` (see
    :func:`substitute_namespace`) before parsing.

    Missing or unreadable meshes follow the fallback in the module docstring and add a warning naming the
    file; with ``fallback=False`` they raise :class:`RobotModelError` instead. An unparsable URDF always
    raises :class:`RobotModelError`. The result follows the contract in the module docstring.
    """
    return _convert(urdf_text, package_paths, namespace=namespace, fallback=fallback, confine=False)


def robot_description_glb(
    urdf_text: str,
    search_paths: PackagePaths,
    *,
    namespace: str = "",
) -> bytes:
    """The model for a robot's ``/robot_description`` string, for the relay to serve; never raises for bad
    input.

    Differences from :func:`urdf_to_glb`: mesh files are read only from inside ``search_paths`` (a robot on
    the network must not make the relay read arbitrary files), warnings are logged rather than returned,
    and a description that cannot be converted at all logs a warning and yields
    :func:`procedural_robot_glb`, so every robot gets a model. CPU-bound (up to a second or two for a
    detailed robot): call it off the event loop.
    """
    try:
        glb, warnings = _convert(urdf_text, search_paths, namespace=namespace, fallback=True, confine=True)
    except RobotModelError as err:
        logger.warning("robot_description: %s; using the procedural robot model instead", err)
        return procedural_robot_glb()
    for warning in warnings:
        logger.warning("robot_description: %s", warning)
    return glb


def procedural_robot_glb() -> bytes:
    """The documented stand-in model when there is no URDF at all: a TurtleBot-sized round base (0.30 m
    across) tinted through ``body``, two dark wheels, a mast with a dark camera head, and a light nose
    pointing forward (ROS ``+x``) so the heading reads at a glance. Same node and material conventions as
    :func:`urdf_to_glb` (``robot`` → ``base_footprint`` → ``base_link`` ...)."""
    glb, warnings = _convert(_PROCEDURAL_URDF, {}, namespace="", fallback=False, confine=True)
    # The built-in description uses primitives only; a warning here would be a bug in this module.
    assert not warnings, warnings
    return glb


# ------------------------------------------------------------------------------------------- conversion


def _convert(
    urdf_text: str, package_paths: PackagePaths, *, namespace: str, fallback: bool, confine: bool
) -> tuple[bytes, list[str]]:
    warnings: list[str] = []
    model = _parse(substitute_namespace(urdf_text, namespace))
    resolver = _MeshResolver(package_paths, confine=confine)
    root = _build_tree(model, resolver, fallback, warnings)
    _apply_triangle_budget(root, MODEL_TRIANGLE_BUDGET)
    glb = _encode_glb(root)
    for warning in warnings:
        logger.debug("urdf_to_glb: %s", warning)
    return glb, warnings


def _parse(urdf_text: str) -> Any:
    """A yourdfpy model with its scene graph (for forward kinematics) but no meshes: we load those."""
    # ElementTree first, for a clear error message: yourdfpy logs and retries with a recovering parser.
    try:
        root = ET.fromstring(urdf_text)
    except ET.ParseError as err:
        raise RobotModelError(f"the URDF is not well-formed XML: {err}") from err
    if root.tag != "robot":
        raise RobotModelError(f"the URDF's root element is <{root.tag}>, expected <robot>")
    _check_tree(root)
    try:
        # Bytes, not str: lxml refuses str input that carries an encoding declaration.
        model = yourdfpy.URDF.load(
            io.BytesIO(urdf_text.encode("utf-8")),
            build_scene_graph=True,
            load_meshes=False,
            build_collision_scene_graph=False,
        )
    except Exception as err:  # yourdfpy raises bare ValueError/KeyError/AttributeError on bad documents
        raise RobotModelError(f"the URDF cannot be parsed: {type(err).__name__}: {err}") from err
    if model.base_link is None:
        raise RobotModelError("the URDF's joints form a loop: no link is without a parent")
    return model


def _check_tree(robot: ET.Element) -> None:
    """Reject what yourdfpy would trip over with an unhelpful message (or loop forever on): no links,
    duplicate links, joints naming links that do not exist, links with two parents, and loops."""
    names = [link.get("name", "") for link in robot.findall("link")]
    if not names:
        raise RobotModelError("the URDF has no <link>")
    if len(set(names)) != len(names):
        duplicate = next(n for n in names if names.count(n) > 1)
        raise RobotModelError(f"link {duplicate!r} is defined twice")
    parent_of: dict[str, str] = {}
    for joint in robot.findall("joint"):
        label = joint.get("name", "?")
        parent, child = joint.find("parent"), joint.find("child")
        parent_link = "" if parent is None else parent.get("link", "")
        child_link = "" if child is None else child.get("link", "")
        for role, link_name in (("parent", parent_link), ("child", child_link)):
            if link_name not in names:
                raise RobotModelError(f"joint {label!r}: {role} link {link_name!r} is not defined")
        if child_link in parent_of:
            raise RobotModelError(f"link {child_link!r} is the child of more than one joint")
        parent_of[child_link] = parent_link
    for name in names:
        # With one parent per link, a walk up that is longer than the number of links is going round a loop.
        link, steps = name, 0
        while link in parent_of:
            link, steps = parent_of[link], steps + 1
            if steps > len(names):
                raise RobotModelError(f"the URDF's joints form a loop through link {name!r}")


def _leaf_name(link_name: str) -> str:
    """``tb3_0/base_link`` → ``base_link``: frame names are compared without their namespace."""
    return link_name.rsplit("/", 1)[-1]


def _build_tree(model: Any, resolver: _MeshResolver, fallback: bool, warnings: list[str]) -> _Node:
    links = {link.name: link for link in model.robot.links}
    children: dict[str, list[str]] = {name: [] for name in links}
    for joint in model.robot.joints:
        if joint.parent not in links or joint.child not in links:
            raise RobotModelError(f"joint {joint.name} connects unknown links {joint.parent} -> {joint.child}")
        children[joint.parent].append(joint.child)

    root_link: str = model.base_link
    anchor = _reference_link(list(links), root_link)

    # Breadth-first from the root: the first link with visuals is the chassis, tinted through `body`.
    # (_check_tree ruled out loops and second parents, so this terminates and visits each link once.)
    order: list[str] = []
    queue = [root_link]
    while queue:
        name = queue.pop(0)
        order.append(name)
        queue.extend(children[name])
    body_link = next((name for name in order if links[name].visuals), None)
    placed: set[str] = set()

    urdf_colours = {m.name: m.color for m in model.robot.materials if m.name is not None and m.color is not None}

    def make_node(name: str, matrix: NDArray[np.float64]) -> _Node:
        node = _Node(name, matrix)
        placed.add(name)
        _add_link_geometry(node, links[name], name == body_link, urdf_colours, resolver, fallback, warnings)
        for child in children[name]:
            node.children.append(make_node(child, _transform(model, child, name)))
        return node

    root = _Node(ROOT_NODE, np.eye(4), extras={"reference_link": anchor, "tint_material": BODY_MATERIAL})
    root_node = make_node(root_link, _transform(model, root_link, anchor))
    root.children.append(root_node)
    for name in links:
        if name not in placed and name not in _parents(model):
            # A second root has no pose relative to the first: keep it (and its subtree) at the root's origin.
            warnings.append(f"link {name} is not connected to {root_link} by joints; placed at its origin")
            root_node.children.append(make_node(name, np.eye(4)))
    return root


def _parents(model: Any) -> set[str]:
    """Links that are the child of some joint."""
    return {joint.child for joint in model.robot.joints}


def _reference_link(link_names: list[str], root_link: str) -> str:
    for wanted in ("base_footprint", "base_link"):
        for name in link_names:
            if _leaf_name(name) == wanted:
                return name
    return root_link


def _transform(model: Any, frame_to: str, frame_from: str) -> NDArray[np.float64]:
    """Pose of ``frame_to`` in ``frame_from`` at the zero joint configuration (yourdfpy's forward kinematics;
    the model was loaded at its zero configuration and never moved)."""
    return np.asarray(model.get_transform(frame_to=frame_to, frame_from=frame_from), dtype=np.float64)


def _srgb_to_linear(value: float) -> float:
    value = min(max(float(value), 0.0), 1.0)
    linear = value / 12.92 if value <= 0.04045 else ((value + 0.055) / 1.055) ** 2.4
    return round(linear, 4)


def _visual_material(link_name: str, visual: Any, is_body: bool, urdf_colours: Mapping[str, Any]) -> _Material:
    if is_body:
        return BODY
    if _WHEEL_NAME.search(_leaf_name(link_name)):
        return TYRE
    material = visual.material
    if material is None:
        return PART
    colour = material.color if material.color is not None else urdf_colours.get(material.name or "")
    if colour is None:
        return PART
    r, g, b, a = (float(c) for c in np.asarray(colour.rgba, dtype=np.float64).reshape(4))
    name = material.name or "urdf_colour"
    if name in _RESERVED_MATERIALS:
        name = f"urdf_{name}"
    # Alpha is linear already in glTF; only the colour channels carry the sRGB curve.
    rgba = (_srgb_to_linear(r), _srgb_to_linear(g), _srgb_to_linear(b), round(min(max(a, 0.0), 1.0), 4))
    return _Material(name, rgba, 0.7)


def _add_link_geometry(
    node: _Node,
    link: Any,
    is_body: bool,
    urdf_colours: Mapping[str, Any],
    resolver: _MeshResolver,
    fallback: bool,
    warnings: list[str],
) -> None:
    used_collision_fallback = False
    for visual in link.visuals:
        material = _visual_material(link.name, visual, is_body, urdf_colours)
        origin = np.eye(4) if visual.origin is None else np.asarray(visual.origin, dtype=np.float64)
        geometry = visual.geometry
        if geometry is None:
            warnings.append(f"link {link.name}: a <visual> has no geometry; skipped")
            continue
        if geometry.mesh is None:
            node.parts.append((material, _primitive(geometry).transformed(origin)))
            continue
        uri: str = geometry.mesh.filename
        try:
            mesh = _load_mesh(uri, geometry.mesh.scale, resolver)
        except _MeshUnavailable as err:
            if not fallback:
                raise RobotModelError(f"link {link.name}: {err}") from err
            if used_collision_fallback:
                # The link's collision geometry already stands in for it once; drawing it twice adds nothing.
                warnings.append(f"link {link.name}: {err}; covered by the collision geometry drawn already")
                continue
            stand_ins, what, from_collision = _fallback_geometry(link, origin, resolver)
            used_collision_fallback = from_collision
            warnings.append(f"link {link.name}: {err}; drew {what} instead")
            node.parts.extend((material, stand_in) for stand_in in stand_ins)
            continue
        node.parts.append((material, mesh.transformed(origin)))


class _MeshUnavailable(Exception):
    """A mesh URI that cannot be turned into triangles; the message names the file and why."""


def _fallback_geometry(
    link: Any, visual_origin: NDArray[np.float64], resolver: _MeshResolver
) -> tuple[list[_Geometry], str, bool]:
    """Stand-ins for a missing visual mesh: the link's collision geometry, else a small box at the visual's
    origin. Returns them, a description for the warning, and whether they came from the collisions."""
    stand_ins: list[_Geometry] = []
    kinds: list[str] = []
    for collision in link.collisions:
        geometry = collision.geometry
        if geometry is None:
            continue
        origin = np.eye(4) if collision.origin is None else np.asarray(collision.origin, dtype=np.float64)
        if geometry.mesh is None:
            stand_ins.append(_primitive(geometry).transformed(origin))
            kinds.append(next(k for k in ("box", "cylinder", "sphere") if getattr(geometry, k) is not None))
            continue
        try:
            stand_ins.append(_load_mesh(geometry.mesh.filename, geometry.mesh.scale, resolver).transformed(origin))
            kinds.append("mesh")
        except _MeshUnavailable:
            continue
    if stand_ins:
        return stand_ins, "its collision geometry (" + ", ".join(kinds) + ")", True
    box = _box((FALLBACK_BOX_SIZE,) * 3).transformed(visual_origin)
    return [box], f"a {FALLBACK_BOX_SIZE * 100:g} cm box", False


# ------------------------------------------------------------------------------------------------ meshes


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


def _walk(node: _Node) -> Iterator[_Node]:
    yield node
    for child in node.children:
        yield from _walk(child)


def _apply_triangle_budget(root: _Node, budget: int) -> None:
    """Simplify the mesh-file geometry of the model in place when it holds more than ``budget`` triangles:
    each mesh gets a share proportional to its triangle count. Primitives are small and stay as they are."""
    meshes = [(node, i) for node in _walk(root) for i, (_, g) in enumerate(node.parts) if not g.smooth]
    total = sum(len(node.parts[i][1].faces) for node, i in meshes)
    if total <= budget:
        return
    for node, i in meshes:
        material, geometry = node.parts[i]
        share = max(1, budget * len(geometry.faces) // total)
        node.parts[i] = (material, _simplify(geometry, share))
    logger.debug("simplified %d mesh triangles to a budget of %d", total, budget)


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


# -------------------------------------------------------------------------------------------- URI lookup


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


# ------------------------------------------------------------------------------------------------- GLB


_ARRAY_BUFFER: Final = 34962
_ELEMENT_ARRAY_BUFFER: Final = 34963
_FLOAT: Final = 5126
_UNSIGNED_SHORT: Final = 5123
_UNSIGNED_INT: Final = 5125


class _GlbBuilder:
    """Accumulates glTF JSON and one binary buffer; :meth:`finish` packs them as GLB."""

    def __init__(self) -> None:
        self.binary = bytearray()
        self.buffer_views: list[dict[str, Any]] = []
        self.accessors: list[dict[str, Any]] = []
        self.meshes: list[dict[str, Any]] = []
        self.materials: list[dict[str, Any]] = []
        self.nodes: list[dict[str, Any]] = []
        self._material_index: dict[_Material, int] = {}

    def _view(self, data: bytes, target: int) -> int:
        self.binary.extend(b"\0" * (-len(self.binary) % 4))  # accessors need 4-byte aligned offsets
        self.buffer_views.append(
            {"buffer": 0, "byteOffset": len(self.binary), "byteLength": len(data), "target": target}
        )
        self.binary.extend(data)
        return len(self.buffer_views) - 1

    def _accessor(self, array: NDArray[Any], component: int, kind: str, target: int, bounds: bool) -> int:
        accessor: dict[str, Any] = {
            "bufferView": self._view(array.tobytes(), target),
            "componentType": component,
            "count": int(array.shape[0]),
            "type": kind,
        }
        if bounds:
            # Exact float32 values: the validator compares min/max with the data bit for bit.
            accessor["min"] = [float(v) for v in array.min(axis=0)]
            accessor["max"] = [float(v) for v in array.max(axis=0)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def material(self, material: _Material) -> int:
        if material not in self._material_index:
            names = {m["name"] for m in self.materials}
            name, suffix = material.name, 2
            while name in names:  # two URDF materials of one name but different colours
                name, suffix = f"{material.name}_{suffix}", suffix + 1
            self.materials.append(
                {
                    "name": name,
                    "pbrMetallicRoughness": {
                        "baseColorFactor": list(material.rgba),
                        "metallicFactor": 0.0,
                        "roughnessFactor": material.roughness,
                    },
                    **({"alphaMode": "BLEND"} if material.rgba[3] < 1.0 else {}),
                }
            )
            self._material_index[material] = len(self.materials) - 1
        return self._material_index[material]

    def mesh(self, name: str, parts: Sequence[tuple[_Material, _Geometry]]) -> int | None:
        """One glTF mesh for a link: a primitive per (material, smooth or flat), in first-use order."""
        groups: dict[tuple[_Material, bool], list[_Geometry]] = {}
        for material, geometry in parts:
            groups.setdefault((material, geometry.smooth), []).append(geometry)
        primitives: list[dict[str, Any]] = []
        for (material, smooth), geometries in groups.items():
            vertices, faces = _concatenate(geometries)
            attributes: dict[str, int] = {}
            if smooth:
                positions, normals, indices = _crease_normals(vertices @ _R.T, faces, CREASE_ANGLE_DEG)
            else:
                positions, indices = _drop_degenerate(vertices @ _R.T, faces)
            if len(indices) == 0:
                continue
            attributes["POSITION"] = self._accessor(positions, _FLOAT, "VEC3", _ARRAY_BUFFER, True)
            if smooth:
                attributes["NORMAL"] = self._accessor(normals, _FLOAT, "VEC3", _ARRAY_BUFFER, False)
            # 16-bit indices halve the index data; 65535 is reserved (primitive restart) so stay below it.
            small = len(positions) < 65535
            index_array = indices.astype(np.uint16 if small else np.uint32).reshape(-1)
            primitives.append(
                {
                    "attributes": attributes,
                    "indices": self._accessor(
                        index_array,
                        _UNSIGNED_SHORT if small else _UNSIGNED_INT,
                        "SCALAR",
                        _ELEMENT_ARRAY_BUFFER,
                        False,
                    ),
                    "material": self.material(material),
                    "mode": 4,
                }
            )
        if not primitives:
            return None
        self.meshes.append({"name": name, "primitives": primitives})
        return len(self.meshes) - 1

    def node(self, node: _Node) -> int:
        index = len(self.nodes)
        entry: dict[str, Any] = {"name": node.name}
        self.nodes.append(entry)
        entry.update(_trs(ROS_TO_GLTF @ node.matrix @ ROS_TO_GLTF.T))
        mesh = self.mesh(node.name, node.parts)
        if mesh is not None:
            entry["mesh"] = mesh
        if node.children:
            entry["children"] = [self.node(child) for child in node.children]
        if node.extras:
            entry["extras"] = dict(node.extras)
        return index

    def finish(self, scene_name: str) -> bytes:
        self.binary.extend(b"\0" * (-len(self.binary) % 4))
        document: dict[str, Any] = {
            "asset": {"version": "2.0", "generator": "xr-relay relay.twin.urdf"},
            "scene": 0,
            "scenes": [{"name": scene_name, "nodes": [0]}],
            "nodes": self.nodes,
        }
        if self.meshes:
            document.update(meshes=self.meshes, materials=self.materials, accessors=self.accessors)
            document.update(bufferViews=self.buffer_views, buffers=[{"byteLength": len(self.binary)}])
        text = json.dumps(document, separators=(",", ":"), allow_nan=False).encode("utf-8")
        text += b" " * (-len(text) % 4)
        chunks = struct.pack("<II", len(text), 0x4E4F534A) + text
        if self.meshes:
            chunks += struct.pack("<II", len(self.binary), 0x004E4942) + bytes(self.binary)
        return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


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


def _clean(value: float) -> float:
    # Rounding keeps 1.57-radian URDF angles from printing 17 digits of noise; +0.0 turns -0.0 into 0.0.
    return round(float(value), 9) + 0.0


def _trs(matrix: NDArray[np.float64]) -> dict[str, list[float]]:
    """glTF ``translation``/``rotation`` of a rigid transform, omitting identity parts."""
    result: dict[str, list[float]] = {}
    translation = [_clean(v) for v in matrix[:3, 3]]
    if any(translation):
        result["translation"] = translation
    quaternion = _quaternion(matrix)
    if abs(quaternion[3] - 1.0) > 1e-12:
        result["rotation"] = [_clean(v) for v in quaternion]
    return result


def _quaternion(matrix: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """Unit quaternion ``(x, y, z, w)`` with ``w >= 0`` of the rotation part of ``matrix`` (Shepperd's
    method, on plain floats: no eigen-solver whose last bits could vary between machines)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = (tuple(float(v) for v in row) for row in matrix[:3, :3])
    trace = r00 + r11 + r22
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        x, y, z, w = (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s, 0.25 * s
    elif r00 > r11 and r00 > r22:
        s = 2.0 * math.sqrt(1.0 + r00 - r11 - r22)
        x, y, z, w = 0.25 * s, (r01 + r10) / s, (r02 + r20) / s, (r21 - r12) / s
    elif r11 > r22:
        s = 2.0 * math.sqrt(1.0 + r11 - r00 - r22)
        x, y, z, w = (r01 + r10) / s, 0.25 * s, (r12 + r21) / s, (r02 - r20) / s
    else:
        s = 2.0 * math.sqrt(1.0 + r22 - r00 - r11)
        x, y, z, w = (r02 + r20) / s, (r12 + r21) / s, 0.25 * s, (r10 - r01) / s
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    sign = -1.0 if w < 0.0 else 1.0  # q and -q are one rotation: w >= 0 keeps the output canonical
    return (sign * x / norm, sign * y / norm, sign * z / norm, sign * w / norm)


def _encode_glb(root: _Node) -> bytes:
    builder = _GlbBuilder()
    builder.node(root)
    return builder.finish(ROOT_NODE)


# ------------------------------------------------------------------------------------- procedural model

# The stand-in robot, as a URDF so it goes through exactly the pipeline (and conventions) of real ones.
# Base: a 0.30 m disc 0.08 m tall on 0.033 m wheels (TurtleBot scale); the nose is a flat square turned 45
# degrees, its top just above the base's, whose corner sticks out 0.05 m ahead: an arrowhead from above.
_PROCEDURAL_URDF: Final = """<?xml version="1.0"?>
<robot name="procedural_robot">
  <material name="camera_dark"><color rgba="0.15 0.15 0.17 1"/></material>
  <material name="mast_grey"><color rgba="0.55 0.55 0.55 1"/></material>
  <material name="nose_light"><color rgba="0.95 0.95 0.9 1"/></material>
  <link name="base_footprint"/>
  <joint name="base_joint" type="fixed">
    <parent link="base_footprint"/><child link="base_link"/><origin xyz="0 0 0.010"/>
  </joint>
  <link name="base_link">
    <visual><origin xyz="0 0 0.045"/><geometry><cylinder radius="0.15" length="0.08"/></geometry></visual>
  </link>
  <joint name="wheel_left_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_left_link"/>
    <origin xyz="0 0.16 0.023" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <link name="wheel_left_link">
    <visual><geometry><cylinder radius="0.033" length="0.02"/></geometry></visual>
  </link>
  <joint name="wheel_right_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_right_link"/>
    <origin xyz="0 -0.16 0.023" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <link name="wheel_right_link">
    <visual><geometry><cylinder radius="0.033" length="0.02"/></geometry></visual>
  </link>
  <joint name="nose_joint" type="fixed">
    <parent link="base_link"/><child link="nose_link"/><origin xyz="0.14 0 0.075"/>
  </joint>
  <link name="nose_link">
    <visual>
      <origin rpy="0 0 0.7853981633974483"/>
      <geometry><box size="0.08 0.08 0.025"/></geometry>
      <material name="nose_light"/>
    </visual>
  </link>
  <joint name="mast_joint" type="fixed">
    <parent link="base_link"/><child link="mast_link"/><origin xyz="-0.04 0 0.085"/>
  </joint>
  <link name="mast_link">
    <visual>
      <origin xyz="0 0 0.11"/><geometry><cylinder radius="0.012" length="0.22"/></geometry>
      <material name="mast_grey"/>
    </visual>
  </link>
  <joint name="camera_joint" type="fixed">
    <parent link="mast_link"/><child link="camera_link"/><origin xyz="0.02 0 0.24"/>
  </joint>
  <link name="camera_link">
    <visual>
      <geometry><box size="0.05 0.12 0.04"/></geometry>
      <material name="camera_dark"/>
    </visual>
  </link>
</robot>
"""
