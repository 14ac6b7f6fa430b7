"""The stand-in robot for when there is no URDF at all, written as a URDF so that it goes through exactly
the pipeline (and conventions) of real ones.

Base: a 0.30 m disc 0.08 m tall on 0.033 m wheels (TurtleBot scale), tinted through ``body``; two dark drive
wheels; a mast with a dark camera head; and a light nose, a flat square turned 45 degrees with its top just
above the base's, whose corner sticks out 0.05 m ahead (ROS ``+x``): an arrowhead from above, so the heading
reads at a glance.
"""

from __future__ import annotations

from typing import Final, NamedTuple

_HEAD: Final = """<?xml version="1.0"?>
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
"""

# Every other part is a link of one visual hanging from a joint: `<name>_link` on `<name>_joint`.
_PART: Final = """  <joint name="{name}_joint" type="{joint}">
    <parent link="{parent}"/><child link="{name}_link"/><origin xyz="{xyz}" rpy="{rpy}"/>{axis}
  </joint>
  <link name="{name}_link">
    <visual>
      <origin xyz="{visual_xyz}" rpy="{visual_rpy}"/><geometry>{geometry}</geometry>{material}
    </visual>
  </link>
"""


class _Part(NamedTuple):
    name: str
    parent: str
    xyz: str
    geometry: str
    material: str = ""
    visual_xyz: str = "0 0 0"
    visual_rpy: str = "0 0 0"
    joint: str = "fixed"
    rpy: str = "0 0 0"
    axis: str = ""


# The drive wheels turn about the wheel's own z (a cylinder's axis), which the joint turns to ROS +y.
_WHEEL: Final = dict(
    parent="base_link",
    geometry='<cylinder radius="0.033" length="0.02"/>',
    joint="continuous",
    rpy="-1.5707963267948966 0 0",
    axis='<axis xyz="0 0 1"/>',
)
_PARTS: Final = (
    _Part("wheel_left", xyz="0 0.16 0.023", **_WHEEL),
    _Part("wheel_right", xyz="0 -0.16 0.023", **_WHEEL),
    _Part(
        "nose",
        parent="base_link",
        xyz="0.14 0 0.075",
        geometry='<box size="0.08 0.08 0.025"/>',
        material="nose_light",
        visual_rpy="0 0 0.7853981633974483",
    ),
    _Part(
        "mast",
        parent="base_link",
        xyz="-0.04 0 0.085",
        geometry='<cylinder radius="0.012" length="0.22"/>',
        material="mast_grey",
        visual_xyz="0 0 0.11",
    ),
    _Part(
        "camera",
        parent="mast_link",
        xyz="0.02 0 0.24",
        geometry='<box size="0.05 0.12 0.04"/>',
        material="camera_dark",
    ),
)


def _part_urdf(part: _Part) -> str:
    material = f'<material name="{part.material}"/>' if part.material else ""
    return _PART.format(**{**part._asdict(), "material": material})


#: The procedural robot's URDF (see the module docstring).
PROCEDURAL_URDF: Final = _HEAD + "".join(_part_urdf(part) for part in _PARTS) + "</robot>\n"
