"""The kinematic tree of a robot model: one node per URDF link, nested as the joints nest them.

Node transforms are the links' poses relative to their parents at the zero joint configuration (yourdfpy's
forward kinematics), in ROS axes; each node holds its link's visuals in the link's own frame. Above the
URDF's root link sits the ``robot`` node (:data:`ROOT_NODE`), at the robot's reference frame:
``base_footprint`` when the URDF has one, else ``base_link``, else the root link.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from .errors import RobotModelError
from .materials import BODY_MATERIAL
from .meshes import MeshResolver
from .parse import leaf_name
from .visuals import Part, link_parts

#: Name of the root node; the client poses the robot through it.
ROOT_NODE: Final = "robot"


@dataclass
class LinkNode:
    """A link: its transform relative to the parent node (ROS axes), geometry in its frame, children."""

    name: str
    matrix: NDArray[np.float64]
    parts: list[Part] = field(default_factory=list)
    children: list[LinkNode] = field(default_factory=list)
    extras: dict[str, str] = field(default_factory=dict)


def walk(node: LinkNode) -> Iterator[LinkNode]:
    """``node`` and every node below it, depth first, parents before children."""
    yield node
    for child in node.children:
        yield from walk(child)


def build_tree(model: Any, resolver: MeshResolver, fallback: bool, warnings: list[str]) -> LinkNode:
    """The ``robot`` node over the links of yourdfpy ``model`` with their visuals (see :mod:`.visuals`).

    The chassis, tinted through ``body``, is the first link with visuals walking breadth-first from the
    root. A link that no joint connects to the root stays at the root link's origin, with a warning.
    """
    links = {link.name: link for link in model.robot.links}
    children: dict[str, list[str]] = {name: [] for name in links}
    for joint in model.robot.joints:
        if joint.parent not in links or joint.child not in links:
            raise RobotModelError(f"joint {joint.name} connects unknown links {joint.parent} -> {joint.child}")
        children[joint.parent].append(joint.child)

    root_link: str = model.base_link
    anchor = _reference_link(list(links), root_link)
    # (parse_urdf ruled out loops and second parents, so this walk terminates and visits each link once.)
    order = _breadth_first(root_link, children)
    body_link = next((name for name in order if links[name].visuals), None)
    placed: set[str] = set()
    urdf_colours = {m.name: m.color for m in model.robot.materials if m.name is not None and m.color is not None}

    def make_node(name: str, matrix: NDArray[np.float64]) -> LinkNode:
        parts = link_parts(links[name], name == body_link, urdf_colours, resolver, fallback, warnings)
        node = LinkNode(name, matrix, parts)
        placed.add(name)
        for child in children[name]:
            node.children.append(make_node(child, _transform(model, child, name)))
        return node

    root = LinkNode(ROOT_NODE, np.eye(4), extras={"reference_link": anchor, "tint_material": BODY_MATERIAL})
    root_node = make_node(root_link, _transform(model, root_link, anchor))
    root.children.append(root_node)
    has_parent = {joint.child for joint in model.robot.joints}
    for name in links:
        if name not in placed and name not in has_parent:
            # A second root has no pose relative to the first: keep it (and its subtree) at the root's origin.
            warnings.append(f"link {name} is not connected to {root_link} by joints; placed at its origin")
            root_node.children.append(make_node(name, np.eye(4)))
    return root


def _breadth_first(root: str, children: Mapping[str, list[str]]) -> list[str]:
    order: list[str] = []
    queue = [root]
    while queue:
        name = queue.pop(0)
        order.append(name)
        queue.extend(children[name])
    return order


def _reference_link(link_names: list[str], root_link: str) -> str:
    for wanted in ("base_footprint", "base_link"):
        for name in link_names:
            if leaf_name(name) == wanted:
                return name
    return root_link


def _transform(model: Any, frame_to: str, frame_from: str) -> NDArray[np.float64]:
    """Pose of ``frame_to`` in ``frame_from`` at the zero joint configuration (yourdfpy's forward kinematics;
    the model was loaded at its zero configuration and never moved)."""
    return np.asarray(model.get_transform(frame_to=frame_to, frame_from=frame_from), dtype=np.float64)
