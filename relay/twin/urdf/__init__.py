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

The package, one concept a module: :mod:`.parse` (URDF text to a checked yourdfpy model), :mod:`.tree` (the
links as a node tree at the zero configuration), :mod:`.visuals` (a link's visuals and their fallback),
:mod:`.materials`, :mod:`.primitives` (boxes, cylinders, spheres), :mod:`.meshes` (package paths and mesh
files), :mod:`.simplify` (the triangle budget), :mod:`.normals`, :mod:`.assembly` (the tree through the one
glTF writer, :mod:`relay.twin.gltf`) and :mod:`.procedural` (the stand-in model).
"""

from __future__ import annotations

import logging
from typing import Final

from .assembly import encode_glb
from .errors import RobotModelError
from .materials import BODY, BODY_MATERIAL, PART, PART_MATERIAL, TYRE, TYRE_MATERIAL
from .meshes import MeshResolver, PackagePaths
from .normals import CREASE_ANGLE_DEG
from .parse import parse_urdf, substitute_namespace
from .procedural import PROCEDURAL_URDF
from .simplify import apply_triangle_budget
from .tree import ROOT_NODE, build_tree
from .visuals import FALLBACK_BOX_SIZE

__all__ = [
    "BODY",
    "BODY_MATERIAL",
    "CREASE_ANGLE_DEG",
    "FALLBACK_BOX_SIZE",
    "MODEL_TRIANGLE_BUDGET",
    "PART",
    "PART_MATERIAL",
    "ROOT_NODE",
    "TYRE",
    "TYRE_MATERIAL",
    "PackagePaths",
    "RobotModelError",
    "procedural_robot_glb",
    "robot_description_glb",
    "substitute_namespace",
    "urdf_to_glb",
]

logger = logging.getLogger(__name__)

#: Most triangles the mesh files of one robot may keep; over it, each is simplified to its share. The Waffle Pi's
#: meshes hold 121 k: drawn whole, the demo's three robots were 726 k triangles a VR frame (two eyes) and the
#: emulated headset on SwiftShader drew 6.2 frames/s; at 50 k it draws 11 (2026-11-25), and the model seen from
#: 40 cm is the same to the eye (20 k, tried too, dented the plates). Four detailed robots stay under 400 k a frame,
#: within a standalone headset's budget.
MODEL_TRIANGLE_BUDGET: Final = 50_000


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
    glb, warnings = _convert(PROCEDURAL_URDF, {}, namespace="", fallback=False, confine=True)
    # The built-in description uses primitives only; a warning here would be a bug in this module.
    assert not warnings, warnings
    return glb


def _convert(
    urdf_text: str, package_paths: PackagePaths, *, namespace: str, fallback: bool, confine: bool
) -> tuple[bytes, list[str]]:
    warnings: list[str] = []
    model = parse_urdf(substitute_namespace(urdf_text, namespace))
    resolver = MeshResolver(package_paths, confine=confine)
    root = build_tree(model, resolver, fallback, warnings)
    apply_triangle_budget(root, MODEL_TRIANGLE_BUDGET)
    glb = encode_glb(root)
    for warning in warnings:
        logger.debug("urdf_to_glb: %s", warning)
    return glb, warnings
