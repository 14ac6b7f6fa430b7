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
import logging
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Final

import numpy as np
import yourdfpy  # type: ignore[import-untyped, unused-ignore]
from numpy.typing import NDArray

from relay.twin.gltf import Geometry, Material, Mesh, Node, Primitive, build_glb
from relay.twin.urdf_meshes import (
    CREASE_ANGLE_DEG,
    PackagePaths,
    _box,
    _concatenate,
    _crease_normals,
    _drop_degenerate,
    _Geometry,
    _load_mesh,
    _MeshResolver,
    _MeshUnavailable,
    _primitive,
    _simplify,
)
from relay.twin.urdf_meshes import (
    RobotModelError as RobotModelError,
)

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
#: Edge of the cube drawn for a missing mesh when the link has no usable collision geometry (metres).
FALLBACK_BOX_SIZE: Final = 0.05

_WHEEL_NAME = re.compile(r"wheel|tyre|tire|caster|track", re.IGNORECASE)
_NAMESPACE_PLACEHOLDER = re.compile(r"\$\{\s*namespace\s*\}")
_RESERVED_MATERIALS: Final = frozenset({BODY_MATERIAL, TYRE_MATERIAL, PART_MATERIAL})


BODY: Final = Material(BODY_MATERIAL, (0.7, 0.7, 0.7, 1.0), roughness=0.6)
TYRE: Final = Material(TYRE_MATERIAL, (0.02, 0.02, 0.02, 1.0), roughness=0.9)
PART: Final = Material(PART_MATERIAL, (0.214, 0.214, 0.214, 1.0), roughness=0.7)


@dataclass
class _Node:
    """A link: its transform relative to the parent node (ROS axes), geometry in its frame, children."""

    name: str
    matrix: NDArray[np.float64]
    parts: list[tuple[Material, _Geometry]] = field(default_factory=list)
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


def _visual_material(link_name: str, visual: Any, is_body: bool, urdf_colours: Mapping[str, Any]) -> Material:
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
    return Material(name, rgba, roughness=0.7, blend=rgba[3] < 1.0)


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


def _encode_glb(root: _Node) -> bytes:
    """The model through the one glTF writer (relay.twin.gltf), ROS frame in, glTF's Y-up frame out."""
    return build_glb([_gltf_node(root, {})], scene_name=ROOT_NODE)


def _gltf_node(node: _Node, names: dict[str, Material]) -> Node:
    """A link as a glTF node: one mesh of a primitive per (material, smooth or flat), in first-use order.

    ``names`` keeps material names unique: two URDF materials of one name but different colours get
    ``name_2``, ``name_3``.
    """
    groups: dict[tuple[Material, bool], list[_Geometry]] = {}
    for material, geometry in node.parts:
        groups.setdefault((material, geometry.smooth), []).append(geometry)
    primitives: list[Primitive] = []
    for (material, smooth), geometries in groups.items():
        vertices, faces = _concatenate(geometries)
        if smooth:
            positions, normals, indices = _crease_normals(vertices, faces, CREASE_ANGLE_DEG)
        else:
            positions, indices = _drop_degenerate(vertices, faces)
            normals = None
        if len(indices) == 0:
            continue
        normals64 = None if normals is None else normals.astype(np.float64)
        triangles = Geometry(positions.astype(np.float64), normals64, indices)
        primitives.append(Primitive(triangles, _unique(material, names)))
    matrix = node.matrix
    return Node(
        node.name,
        mesh=Mesh(node.name, tuple(primitives)) if primitives else None,
        translation=(float(matrix[0, 3]), float(matrix[1, 3]), float(matrix[2, 3])),
        rotation=_quaternion(matrix),
        children=tuple(_gltf_node(child, names) for child in node.children),
        extras=dict(node.extras) if node.extras else None,
    )


def _unique(material: Material, names: dict[str, Material]) -> Material:
    name, suffix = material.name, 2
    while name in names and names[name] != replace(material, name=name):
        name, suffix = f"{material.name}_{suffix}", suffix + 1
    unique = replace(material, name=name)
    names[name] = unique
    return unique


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


# ------------------------------------------------------------------------------------- procedural model

# The stand-in robot, as a URDF so it goes through exactly the pipeline (and conventions) of real ones.
# Base: a 0.30 m disc 0.08 m tall on 0.033 m wheels (TurtleBot scale); the nose is a flat square turned 45
# degrees, its top just above the base's, whose corner sticks out 0.05 m ahead: an arrowhead from above.
_PROCEDURAL_URDF_TEMPLATE: Final = """<?xml version="1.0"?>
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
{wheels}  <joint name="nose_joint" type="fixed">
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
# The two drive wheels differ only in their side (joint axes along the wheel's own z, turned to ROS +y).
_WHEEL: Final = """  <joint name="wheel_{side}_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_{side}_link"/>
    <origin xyz="0 {y} 0.023" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
  </joint>
  <link name="wheel_{side}_link">
    <visual><geometry><cylinder radius="0.033" length="0.02"/></geometry></visual>
  </link>
"""
_PROCEDURAL_URDF: Final = _PROCEDURAL_URDF_TEMPLATE.replace(
    "{wheels}", "".join(_WHEEL.format(side=side, y=y) for side, y in (("left", "0.16"), ("right", "-0.16")))
)
