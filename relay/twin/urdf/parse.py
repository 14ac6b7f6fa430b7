"""Reading a URDF document: namespace placeholders, well-formedness, a sound kinematic tree, yourdfpy's model.

External XML entities are not resolved (lxml >= 5 default), so an untrusted description cannot make the relay
read files through them.
"""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
from typing import Any

import yourdfpy  # type: ignore[import-untyped, unused-ignore]

from .errors import RobotModelError

_NAMESPACE_PLACEHOLDER = re.compile(r"\$\{\s*namespace\s*\}")


def substitute_namespace(urdf_text: str, namespace: str = "") -> str:
    """``urdf_text`` with every ``${namespace}`` placeholder replaced by ``namespace`` verbatim.

    TurtleBot3's URDFs write frame names as ``${namespace}base_link``, so pass ``"tb3_0/"`` (with its slash)
    to get ``tb3_0/base_link``; the default ``""`` strips the placeholders.
    """
    return _NAMESPACE_PLACEHOLDER.sub(lambda _: namespace, urdf_text)


def leaf_name(link_name: str) -> str:
    """``tb3_0/base_link`` → ``base_link``: frame names are compared without their namespace."""
    return link_name.rsplit("/", 1)[-1]


def parse_urdf(urdf_text: str) -> Any:
    """A yourdfpy model with its scene graph (for forward kinematics) but no meshes: we load those.

    Raises :class:`RobotModelError` saying what is wrong with a document that is not a usable URDF.
    """
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
