"""A robot's ``arm:`` entry in robots.yaml: its URDF chain, MoveIt Servo's topics, speed and workspace limits.

The topics' defaults are the names the TurtleBot3 with OpenManipulator-X uses (turtlebot3_manipulation, ROBOTIS):
``joint_states`` from ros2_control's joint_state_broadcaster; ``servo_node/delta_twist_cmds``, MoveIt Servo's
``cartesian_command_in_topic: ~/delta_twist_cmds`` for its default node name ``servo_node`` (moveit_servo.yaml);
``arm_controller/joint_trajectory`` (moveit_servo.yaml's ``command_out_topic``, the JointTrajectoryController
``arm_controller``); ``gripper_controller/gripper_cmd``, the GripperActionController's action (moveit_controllers.yaml,
``action_ns: gripper_cmd``). Upstream they are absolute (one robot); here they are inside the robot's namespace.
"""

from __future__ import annotations

from pathlib import Path

from yaml.nodes import Node

from .model import Arm, ArmTopics, Workspace
from .reader import _FRAME, _Reader, _topic, resolve_topic, speed_limits

ARM_FIELDS = (
    "urdf", "base_link", "tip_link", "gripper_joint", "topics", "limits", "workspace", "joint_margin", "camera",
    "srdf", "optional",
)  # fmt: skip
#: The ``topics`` keys and their defaults, relative to the robot's namespace (the module's docstring says whence).
TOPIC_DEFAULTS = {
    "joint_states": "joint_states",
    "delta_twist_cmds": "servo_node/delta_twist_cmds",
    "joint_trajectory": "arm_controller/joint_trajectory",
    "gripper_cmd": "gripper_controller/gripper_cmd",
}
#: ``urdf: robot_description``: the URDF is the robot's robot_description parameter, not a file.
ROBOT_DESCRIPTION = "robot_description"


def arm(reader: _Reader, node: Node, path: str, namespace: str, base_dir: Path | None, cameras: tuple[str, ...]) -> Arm:
    """The ``arm`` mapping at ``path`` of a robot whose namespace and camera names are given."""
    f = reader.mapping(node, path, ARM_FIELDS, required=("urdf", "base_link", "tip_link", "limits", "workspace"))

    def frame(n: Node, p: str) -> str:
        return reader.string(n, p, pattern=_FRAME, expected="a link name of the URDF")

    # ``optional``: the arm's files may be absent (shared data outside the repository); the robot then runs without
    # its arm and the backend says so (relay/arm/fleet_arms.py), instead of the whole file being refused.
    optional = reader.get(f, "optional", path, reader.boolean, False)
    camera = reader.get(f, "camera", path, lambda n, p: reader.string(n, p, expected="a camera name"), None)
    if camera is not None and camera not in cameras:
        known = ", ".join(cameras) if cameras else "none"
        raise reader.fail(f["camera"], f"{path}.camera", f'no camera "{camera}" on this robot (its cameras: {known})')
    return Arm(
        urdf=_urdf(reader, f["urdf"], f"{path}.urdf", base_dir, optional),
        base_link=frame(f["base_link"], f"{path}.base_link"),
        tip_link=frame(f["tip_link"], f"{path}.tip_link"),
        gripper_joint=reader.get(f, "gripper_joint", path, frame, None),
        topics=_topics(reader, f.get("topics"), f"{path}.topics", namespace),
        limits=speed_limits(reader, f["limits"], f"{path}.limits"),
        workspace=_workspace(reader, f["workspace"], f"{path}.workspace"),
        joint_margin=reader.get(
            f, "joint_margin", path, lambda n, p: reader.number(n, p, non_negative=True), Arm.joint_margin
        ),
        camera=camera,
        srdf=_file(reader, f["srdf"], f"{path}.srdf", base_dir, optional, "an SRDF's path") if "srdf" in f else None,
        optional=optional,
    )


def _urdf(reader: _Reader, node: Node, path: str, base_dir: Path | None, optional: bool) -> Path | None:
    expected = f"a URDF file's path or {ROBOT_DESCRIPTION}"
    if reader.string(node, path, expected=expected) == ROBOT_DESCRIPTION:
        return None
    return _file(reader, node, path, base_dir, optional, expected)


def _file(reader: _Reader, node: Node, path: str, base_dir: Path | None, optional: bool, expected: str) -> Path:
    """A file's path relative to robots.yaml; it must exist unless the arm is ``optional``."""
    file = Path(reader.string(node, path, expected=expected))
    if base_dir is not None and not file.is_absolute():
        file = base_dir / file
    if not optional and not file.is_file():
        raise reader.fail(node, path, f"no such file: {file}")
    return file


def _topics(reader: _Reader, node: Node | None, path: str, namespace: str) -> ArmTopics:
    fields = reader.mapping(node, path, tuple(TOPIC_DEFAULTS)) if node is not None else {}
    topics = {
        key: _topic(reader, fields[key], f"{path}.{key}", namespace)
        if key in fields
        else resolve_topic(namespace, default)
        for key, default in TOPIC_DEFAULTS.items()
    }
    return ArmTopics(**topics)


def _workspace(reader: _Reader, node: Node, path: str) -> Workspace:
    f = reader.mapping(node, path, ("min", "max"), required=("min", "max"))
    low = _point(reader, f["min"], f"{path}.min")
    high = _point(reader, f["max"], f"{path}.max")
    for axis, lo, hi in zip("xyz", low, high, strict=True):
        if not lo < hi:
            raise reader.fail(f["max"], f"{path}.max", f"{axis} must be above min's ({lo:g}), got {hi:g}")
    return Workspace(low, high)


def _point(reader: _Reader, node: Node, path: str) -> tuple[float, float, float]:
    items = [reader.number(n, f"{path}[{i}]") for i, n in reader.sequence(node, path)]
    if len(items) != 3:
        raise reader.fail(node, path, f"expected [x, y, z] (3 numbers, metres), got {len(items)} numbers")
    return items[0], items[1], items[2]
