"""The materials of a robot model: the tintable body, dark tyres, and the URDF's own colours.

See the contract in :mod:`relay.twin.urdf`: the chassis is ``body`` whatever the URDF says (the client tints
it with the robot's colour), wheels are ``tyre``, any other link keeps its URDF colour or is ``part``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import replace
from typing import Any, Final

import numpy as np

from ..gltf import Material
from .parse import leaf_name

#: Name of the tintable chassis material (see the module docstring).
BODY_MATERIAL: Final = "body"
#: Name of the dark material of wheels, tyres, casters and tracks.
TYRE_MATERIAL: Final = "tyre"
#: Name of the default material of links without a URDF colour.
PART_MATERIAL: Final = "part"

BODY: Final = Material(BODY_MATERIAL, (0.7, 0.7, 0.7, 1.0), roughness=0.6)
TYRE: Final = Material(TYRE_MATERIAL, (0.02, 0.02, 0.02, 1.0), roughness=0.9)
PART: Final = Material(PART_MATERIAL, (0.214, 0.214, 0.214, 1.0), roughness=0.7)

_WHEEL_NAME = re.compile(r"wheel|tyre|tire|caster|track", re.IGNORECASE)
_RESERVED_MATERIALS: Final = frozenset({BODY_MATERIAL, TYRE_MATERIAL, PART_MATERIAL})


def visual_material(link_name: str, visual: Any, is_body: bool, urdf_colours: Mapping[str, Any]) -> Material:
    """The material of one ``<visual>`` of link ``link_name``; ``urdf_colours`` holds the colours of the
    URDF's top-level ``<material>`` elements, by name, for visuals that name one without a colour."""
    if is_body:
        return BODY
    if _WHEEL_NAME.search(leaf_name(link_name)):
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


def unique_name(material: Material, names: dict[str, Material]) -> Material:
    """``material``, renamed ``name_2``, ``name_3``... when ``names`` (updated here) already holds another
    material of its name: two URDF materials of one name but different colours stay two materials."""
    name, suffix = material.name, 2
    while name in names and names[name] != replace(material, name=name):
        name, suffix = f"{material.name}_{suffix}", suffix + 1
    unique = replace(material, name=name)
    names[name] = unique
    return unique


def _srgb_to_linear(value: float) -> float:
    value = min(max(float(value), 0.0), 1.0)
    linear = value / 12.92 if value <= 0.04045 else ((value + 0.055) / 1.055) ** 2.4
    return round(linear, 4)
