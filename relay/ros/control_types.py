"""What ros2_control's arm and gripper controllers take, in rosbags' type store and as CDR bytes: a named pose as
trajectory_msgs/JointTrajectory (the arm controller's ``joint_trajectory`` topic; rosbags knows the type) and a gripper
position as a goal of control_msgs' GripperCommand action (the gripper controller's ``gripper_cmd``; the PyPI ROS
wheels and rosbags lack control_msgs, so its definitions are here). No I/O.

**The definitions** are control_msgs' own (ros-controls/control_msgs, ``msg/GripperCommand.msg`` and
``action/GripperCommand.action``, unchanged from Humble to Kilted), split by relay/ros/idl_types.py's
:func:`~relay.ros.idl_types.action_types` as rosidl splits them.
"""

from __future__ import annotations

import math
import uuid
from typing import Any, Final

from .idl_types import Decode, Typesdict, action_types, goal_id_message, message_type

JOINT_TRAJECTORY: Final = "trajectory_msgs/msg/JointTrajectory"
GRIPPER_COMMAND_MSG: Final = "control_msgs/msg/GripperCommand"
GRIPPER_COMMAND: Final = "control_msgs/action/GripperCommand"
SEND_GOAL_REQUEST: Final = f"{GRIPPER_COMMAND}_SendGoal_Request"
SEND_GOAL_RESPONSE: Final = f"{GRIPPER_COMMAND}_SendGoal_Response"

#: control_msgs/msg/GripperCommand.msg: where the gripper goes (m or rad of its joint) and the effort it may use.
GRIPPER_COMMAND_MSG_TEXT: Final = "float64 position\nfloat64 max_effort\n"
#: control_msgs/action/GripperCommand.action.
GRIPPER_COMMAND_ACTION: Final = """\
control_msgs/GripperCommand command
---
float64 position
float64 effort
bool stalled
bool reached_goal
---
float64 position
float64 effort
bool stalled
bool reached_goal
"""


def control_types() -> Typesdict:
    """The gripper command's message and the messages rosidl makes of its action."""
    command = message_type(GRIPPER_COMMAND_MSG_TEXT, GRIPPER_COMMAND_MSG)
    return command | action_types(GRIPPER_COMMAND, GRIPPER_COMMAND_ACTION)


def register(store: Any) -> Any:
    """Add GripperCommand's types to ``store`` (those it lacks); returns it."""
    store.register({name: definition for name, definition in control_types().items() if name not in store.types})
    return store


def _duration(store: Any, seconds: float) -> Any:
    sec = int(seconds)
    return store.types["builtin_interfaces/msg/Duration"](sec=sec, nanosec=int((seconds - sec) * 1e9))


def joint_trajectory(store: Any, names: tuple[str, ...], positions: tuple[float, ...], seconds: float) -> bytes:
    """A one-point JointTrajectory's CDR: the joints at ``positions`` ``seconds`` after the controller takes it (a
    zero header stamp: start at once), standing still there."""
    import numpy as np

    t = store.types
    zero = np.zeros(len(names), dtype=np.float64)
    point = t["trajectory_msgs/msg/JointTrajectoryPoint"](
        positions=np.asarray(positions, dtype=np.float64), velocities=zero, accelerations=zero,
        effort=np.zeros(0, dtype=np.float64), time_from_start=_duration(store, seconds),
    )  # fmt: skip
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="")
    message = t[JOINT_TRAJECTORY](header=header, joint_names=list(names), points=[point])
    return bytes(store.serialize_cdr(message, JOINT_TRAJECTORY))


def gripper_goal(store: Any, position: float, max_effort: float = 0.0, goal_id: bytes | None = None) -> bytes:
    """A GripperCommand SendGoal request's CDR, under a new goal id unless one is given."""
    if not math.isfinite(position):
        raise ValueError("a gripper position must be finite")
    t = store.types
    goal = t[f"{GRIPPER_COMMAND}_Goal"](command=t[GRIPPER_COMMAND_MSG](position=position, max_effort=max_effort))
    request = t[SEND_GOAL_REQUEST](goal_id=goal_id_message(store, goal_id or uuid.uuid4().bytes), goal=goal)
    return bytes(store.serialize_cdr(request, SEND_GOAL_REQUEST))


def read_gripper_goal(data: bytes, decode: Decode) -> float:
    """The position of a GripperCommand SendGoal request (what a gripper controller reads)."""
    return float(decode(data, SEND_GOAL_REQUEST).goal.command.position)


def read_accepted(data: bytes, decode: Decode) -> bool:
    """Whether the gripper controller accepted the goal (its SendGoal response)."""
    return bool(decode(data, SEND_GOAL_RESPONSE).accepted)


def accepted_response(store: Any, accepted: bool) -> bytes:
    """A SendGoal response's CDR (what a gripper controller answers)."""
    t = store.types
    stamp = t["builtin_interfaces/msg/Time"](sec=0, nanosec=0)
    return bytes(store.serialize_cdr(t[SEND_GOAL_RESPONSE](accepted=accepted, stamp=stamp), SEND_GOAL_RESPONSE))
