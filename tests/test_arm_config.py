"""robots.yaml's ``arm:`` entry: a good one parses with MoveIt Servo's topics in the robot's namespace, and every
malformed field is an error naming the robot's entry and the field."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from relay.config import Limits, parse_config
from relay.errors import ConfigError

ROBOT = """\
robots:
  - name: alpha
    limits: {linear: 0.5, angular: 1.0}
    cameras: [{name: wrist}]
"""
ARM = """\
    arm:
      urdf: arm.urdf
      base_link: base_link
      tip_link: end_effector_link
      limits: {linear: 0.1, angular: 0.5}
      workspace: {min: [-0.1, -0.3, 0.0], max: [0.4, 0.3, 0.5]}
"""


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "arm.urdf").write_text("<robot/>", encoding="utf-8")  # the config only checks that it is there
    return tmp_path


def test_a_good_entry_parses_with_the_defaults(folder: Path) -> None:
    arm = parse_config(ROBOT + ARM, base_dir=folder).robots[0].arm
    assert arm is not None
    assert arm.urdf == folder / "arm.urdf"
    assert (arm.base_link, arm.tip_link, arm.gripper_joint, arm.camera) == (
        "base_link",
        "end_effector_link",
        None,
        None,
    )
    assert arm.limits == Limits(0.1, 0.5)
    assert (arm.workspace.min, arm.workspace.max) == ((-0.1, -0.3, 0.0), (0.4, 0.3, 0.5))
    assert arm.joint_margin == 0.1  # MoveIt Servo's joint_limit_margin
    topics = arm.topics
    assert topics.joint_states == "/alpha/joint_states"
    assert topics.delta_twist_cmds == "/alpha/servo_node/delta_twist_cmds"
    assert topics.joint_trajectory == "/alpha/arm_controller/joint_trajectory"
    assert topics.gripper_cmd == "/alpha/gripper_controller/gripper_cmd"


def test_a_robot_without_an_arm_has_none() -> None:
    assert parse_config(ROBOT).robots[0].arm is None


def test_every_key_can_be_set_and_the_urdf_can_be_the_robot_description(folder: Path) -> None:
    text = (
        ROBOT
        + ARM.replace("urdf: arm.urdf", "urdf: robot_description")
        + textwrap.indent(
            textwrap.dedent("""\
            gripper_joint: gripper_left_joint
            joint_margin: 0.05
            camera: wrist
            topics: {joint_states: /joint_states, delta_twist_cmds: servo/twist, joint_trajectory: arm/traj,
                     gripper_cmd: /gripper}
        """),
            "      ",
        )
    )
    arm = parse_config(text, base_dir=folder).robots[0].arm
    assert arm is not None
    assert arm.urdf is None  # the robot's robot_description parameter
    assert (arm.gripper_joint, arm.joint_margin, arm.camera) == ("gripper_left_joint", 0.05, "wrist")
    assert (arm.topics.joint_states, arm.topics.delta_twist_cmds) == ("/joint_states", "/alpha/servo/twist")
    assert (arm.topics.joint_trajectory, arm.topics.gripper_cmd) == ("/alpha/arm/traj", "/gripper")
    assert arm.workspace.contains(0.2, 0.0, 0.2) and not arm.workspace.contains(0.2, 0.0, 0.6)


@pytest.mark.parametrize(
    ("old", "new", "field", "message"),
    [
        ("urdf: arm.urdf", "urdf: missing.urdf", "arm.urdf", "no such file"),
        ("urdf: arm.urdf", "urdf: [a]", "arm.urdf", "expected a URDF file's path or robot_description"),
        ("      urdf: arm.urdf\n", "", "arm.urdf", "is required"),
        ("base_link: base_link", "base_link: 'a b'", "arm.base_link", "expected a link name"),
        ("      tip_link: end_effector_link\n", "", "arm.tip_link", "is required"),
        ("{linear: 0.1,", "{linear: -1,", "arm.limits.linear", "expected a positive number"),
        ("angular: 0.5}", "angular: fast}", "arm.limits.angular", "expected a positive number"),
        ("{linear: 0.1, angular: 0.5}", "{linear: 0.1}", "arm.limits.angular", "is required"),
        ("min: [-0.1, -0.3, 0.0]", "min: [-0.1, -0.3]", "arm.workspace.min", "expected [x, y, z]"),
        ("max: [0.4, 0.3, 0.5]", "max: [0.4, 0.3, up]", "arm.workspace.max[2]", "expected a number"),
        ("max: [0.4, 0.3, 0.5]", "max: [0.4, -0.3, 0.5]", "arm.workspace.max", "y must be above min's"),
        ("workspace: {", "workspace: {centre: 1, ", "arm.workspace.centre", "unknown field"),
        ("urdf: arm.urdf", "urdf: arm.urdf\n      reach: 2", "arm.reach", "unknown field"),
        ("urdf: arm.urdf", "urdf: arm.urdf\n      camera: nose", "arm.camera", 'no camera "nose" on this robot'),
        ("urdf: arm.urdf", "urdf: arm.urdf\n      joint_margin: -1", "arm.joint_margin", "expected a number >= 0"),
        ("urdf: arm.urdf", "urdf: arm.urdf\n      gripper_joint: 3", "arm.gripper_joint", "expected a link name"),
        ("urdf: arm.urdf", "urdf: arm.urdf\n      topics: {twist: a}", "arm.topics.twist", "unknown field"),
        ("urdf: arm.urdf", "urdf: arm.urdf\n      topics: {joint_states: 'a b'}", "arm.topics.joint_states",
         "expected a ROS topic name"),
    ],
)  # fmt: skip
def test_each_malformed_field_is_an_error_naming_it(folder: Path, old: str, new: str, field: str, message: str) -> None:
    assert old in ARM
    with pytest.raises(ConfigError) as info:
        parse_config(ROBOT + ARM.replace(old, new), "robots.yaml", base_dir=folder)
    assert info.value.field == f"robots[0].{field}"
    assert message in info.value.message
    assert str(info.value).startswith("robots.yaml:")  # with the line


def test_an_arm_that_is_not_a_mapping_is_named() -> None:
    with pytest.raises(ConfigError, match=r"robots\[0\]\.arm: expected a mapping"):
        parse_config(ROBOT + "    arm: yes\n")
