"""The arm's chain read from the real TurtleBot3 with OpenManipulator-X URDF: joints, limits, gripper, the zero pose;
and what a URDF without a usable chain is told."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from relay.arm.kinematics import forward
from relay.arm.model import arm_from_urdf, load_joint_limits, with_joint_limits
from relay.arm.srdf import group_states, load_group_states
from relay.twin.urdf.errors import RobotModelError
from tests.helpers.arm import PLANAR_URDF, omx, tb3_manipulation


def urdf_joints() -> dict[str, ET.Element]:
    root = ET.parse(tb3_manipulation("turtlebot3_manipulation.urdf")).getroot()
    return {j.get("name", ""): j for j in root.findall("joint")}  # not those of <ros2_control>


def test_the_chain_is_joint1_to_joint4_with_the_limits_the_file_gives() -> None:
    model = omx()
    assert model.names == ("joint1", "joint2", "joint3", "joint4")
    joints = urdf_joints()
    for joint in model.joints:
        limit = joints[joint.name].find("limit")
        assert limit is not None
        assert joint.kind == "revolute"
        assert joint.lower == pytest.approx(float(limit.get("lower", "nan")))
        assert joint.upper == pytest.approx(float(limit.get("upper", "nan")))
        assert joint.velocity == pytest.approx(float(limit.get("velocity", "nan")))
        axis = joints[joint.name].find("axis")
        assert axis is not None
        assert joint.axis == pytest.approx([float(v) for v in axis.get("xyz", "").split()])
    # The xacro's expressions (PROVENANCE.txt): joint1 +-0.9 pi, joint2 -0.57 pi .. 0.5 pi.
    assert (model.lower[0], model.upper[0]) == pytest.approx((-0.9 * np.pi, 0.9 * np.pi))
    assert (model.lower[1], model.upper[1]) == pytest.approx((-0.57 * np.pi, 0.5 * np.pi))


def test_the_gripper_is_apart_from_the_chain_with_its_mimic() -> None:
    model = omx()
    assert model.gripper is not None
    assert model.gripper.name == "gripper_left_joint"
    assert model.gripper.name not in model.names
    assert model.gripper.kind == "prismatic"
    assert (model.gripper.lower, model.gripper.upper) == pytest.approx((-0.010, 0.019))
    assert [m[0] for m in model.gripper.mimics] == ["gripper_right_joint"]


def test_the_zero_pose_puts_the_tip_where_the_urdf_origins_compose() -> None:
    joints = urdf_joints()
    chain = ["base_fixed", "joint1", "joint2", "joint3", "joint4", "end_effector_joint"]
    total = np.zeros(3)
    for name in chain:
        origin = joints[name].find("origin")
        assert origin is not None
        assert [float(v) for v in origin.get("rpy", "0 0 0").split()] == [0.0, 0.0, 0.0]  # so origins just add up
        total += [float(v) for v in origin.get("xyz", "").split()]
    tip = forward(omx(), [0.0, 0.0, 0.0, 0.0])
    assert np.linalg.norm(tip[:3, 3] - total) < 1e-3
    # PROVENANCE.txt's check with yourdfpy: (0.194, 0, 0.3055) in base_footprint, which is 0.010 below base_link.
    assert tip[:3, 3] == pytest.approx([0.194, 0.0, 0.3055 - 0.010], abs=1e-3)
    assert tip[:3, :3] == pytest.approx(np.eye(3))


def test_the_base_links_collision_box_is_the_body_to_keep_clear_of() -> None:
    (low, high), *others = omx().base_boxes
    assert not others
    # <collision> of base_link: a 0.266 x 0.266 x 0.094 box centred at (-0.064, 0, 0.047).
    assert low == pytest.approx([-0.064 - 0.133, -0.133, 0.0])
    assert high == pytest.approx([-0.064 + 0.133, 0.133, 0.094])


def test_the_srdf_names_home_for_the_arm_and_open_and_close_for_the_gripper() -> None:
    states = load_group_states(tb3_manipulation("config", "turtlebot3_manipulation.srdf"))
    assert states["arm"]["home"] == {"joint1": 0.0, "joint2": -1.0, "joint3": 0.7, "joint4": 0.3}
    assert set(states["gripper"]) == {"open", "close"}


def test_a_bad_srdf_is_told_what_is_wrong() -> None:
    with pytest.raises(RobotModelError, match="not usable XML"):
        group_states("<robot>")
    with pytest.raises(RobotModelError, match="joint1"):
        group_states('<robot><group_state name="a" group="arm"><joint name="joint1" value="x"/></group_state></robot>')


@pytest.mark.parametrize(
    ("base", "tip", "gripper", "message"),
    [
        ("base_link", "nowhere", None, "tip_link 'nowhere' is not a link"),
        ("tip", "base_link", None, "'base_link' is not below base_link 'tip'"),
        ("fore", "tip", None, "no revolute or prismatic joint"),
        ("base_link", "tip", "elbow", "gripper_joint 'elbow' is on the arm's chain"),
        ("base_link", "tip", "thumb", "gripper_joint 'thumb' is not a joint"),
    ],
)
def test_a_urdf_without_the_chain_asked_for_is_told_which(
    base: str, tip: str, gripper: str | None, message: str
) -> None:
    with pytest.raises(RobotModelError, match=message):
        arm_from_urdf(PLANAR_URDF, base, tip, gripper)


def test_a_joint_without_a_velocity_limit_is_named() -> None:
    urdf = PLANAR_URDF.replace(
        'velocity="2" effort="1"/>\n  </joint>\n  <joint name="elbow"',
        'effort="1"/>\n  </joint>\n  <joint name="elbow"',
    )
    with pytest.raises(RobotModelError, match="'shoulder' has no positive velocity limit"):
        arm_from_urdf(urdf, "base_link", "tip")


def test_moveits_joint_limits_file_narrows_nothing_of_this_urdf() -> None:
    # turtlebot3_manipulation's joint_limits.yaml gives every joint the URDF's 4.8 rad/s, and no positions.
    model = omx()
    narrowed = load_joint_limits(model, tb3_manipulation("config", "joint_limits.yaml"))
    assert [(j.lower, j.upper, j.velocity) for j in narrowed.joints] == [
        (j.lower, j.upper, j.velocity) for j in model.joints
    ]


def test_joint_limits_narrow_the_urdfs_but_never_widen_them() -> None:
    model = arm_from_urdf(PLANAR_URDF, "base_link", "tip")
    narrowed = with_joint_limits(
        model,
        {
            "shoulder": {"has_velocity_limits": True, "max_velocity": 0.5, "has_position_limits": True,
                         "min_position": -1.0, "max_position": 9.0},
            "elbow": {"has_velocity_limits": False, "max_velocity": 0.1},
        },
    )  # fmt: skip
    shoulder, elbow = narrowed.joints
    assert (shoulder.lower, shoulder.upper, shoulder.velocity) == (-1.0, 1.5, 0.5)  # 9.0 would widen the URDF's 1.5
    assert (elbow.lower, elbow.upper, elbow.velocity) == (-2.5, 2.5, 2.0)  # no velocity limit asked for
    with pytest.raises(RobotModelError, match="'elbow'"):
        with_joint_limits(model, {"elbow": {"has_velocity_limits": True, "max_velocity": "fast"}})
