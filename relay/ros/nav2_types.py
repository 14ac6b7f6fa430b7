"""Nav2's NavigateToPose action and action_msgs' CancelGoal service in rosbags' type store, and the snapshots the relay
reads from their CDR bytes: what the ``ros`` and ``zenoh`` backends need to follow a Nav2 goal without nav2_msgs
installed (the PyPI ROS wheels have none). No I/O.

**The definitions** are Nav2 Jazzy's own: ``nav2_msgs/action/NavigateToPose.action`` of ros-navigation/navigation2,
branch ``jazzy`` at f4108e5b1c2bce804a1aa0c7be6673a8eb4a1501, and ``action_msgs/srv/CancelGoal.srv`` (ROS 2 Jazzy
and Kilted alike), split into messages as rosidl splits them (relay/ros/idl_types.py), so the RIHS01 hashes rosbags
computes are those of the definitions above.

**The type store** is the one the project uses everywhere (``relay.ros.ros_env.typestore``: the running
distribution's, else the latest), with these types and control_msgs' GripperCommand added (:func:`typestore`).
rosbags' objects have rclpy's attribute names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Final

from . import control_types
from .idl_types import Decode, action_types, goal_id_message, service_types

#: nav2_msgs/action/NavigateToPose.action, Nav2 Jazzy (see the module's docstring).
NAVIGATE_TO_POSE_ACTION: Final = """\
#goal definition
geometry_msgs/PoseStamped pose
string behavior_tree
---
#result definition

# Error codes
# Note: The expected priority order of the errors should match the message order
uint16 NONE=0

uint16 error_code
string error_msg
---
#feedback definition
geometry_msgs/PoseStamped current_pose
builtin_interfaces/Duration navigation_time
builtin_interfaces/Duration estimated_time_remaining
int16 number_of_recoveries
float32 distance_remaining
"""

#: action_msgs/srv/CancelGoal.srv without its comments, ``GoalInfo`` written with its package (rosidl reads the bare
#: name as the package's message; rosbags would look for it in ``action_msgs/srv``).
CANCEL_GOAL_SRV: Final = """\
action_msgs/GoalInfo goal_info
---
int8 ERROR_NONE=0
int8 ERROR_REJECTED=1
int8 ERROR_UNKNOWN_GOAL_ID=2
int8 ERROR_GOAL_TERMINATED=3
int8 return_code
action_msgs/GoalInfo[] goals_canceling
"""

NAVIGATE_TO_POSE: Final = "nav2_msgs/action/NavigateToPose"
FEEDBACK_MESSAGE: Final = f"{NAVIGATE_TO_POSE}_FeedbackMessage"
GET_RESULT_REQUEST: Final = f"{NAVIGATE_TO_POSE}_GetResult_Request"
GET_RESULT_RESPONSE: Final = f"{NAVIGATE_TO_POSE}_GetResult_Response"
CANCEL_GOAL: Final = "action_msgs/srv/CancelGoal"
CANCEL_REQUEST: Final = f"{CANCEL_GOAL}_Request"
CANCEL_RESPONSE: Final = f"{CANCEL_GOAL}_Response"
STATUS_ARRAY: Final = "action_msgs/msg/GoalStatusArray"

# action_msgs/msg/GoalStatus
STATUS_UNKNOWN: Final = 0
STATUS_ACCEPTED: Final = 1
STATUS_EXECUTING: Final = 2
STATUS_CANCELING: Final = 3
STATUS_SUCCEEDED: Final = 4
STATUS_CANCELED: Final = 5
STATUS_ABORTED: Final = 6
ACTIVE: Final = frozenset({STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_CANCELING})
STATUS_NAMES: Final = {
    STATUS_UNKNOWN: "UNKNOWN", STATUS_ACCEPTED: "ACCEPTED", STATUS_EXECUTING: "EXECUTING",
    STATUS_CANCELING: "CANCELING", STATUS_SUCCEEDED: "SUCCEEDED", STATUS_CANCELED: "CANCELED",
    STATUS_ABORTED: "ABORTED",
}  # fmt: skip

# action_msgs/srv/CancelGoal's return codes
CANCEL_ERROR_NONE: Final = 0
CANCEL_ERROR_REJECTED: Final = 1
CANCEL_ERROR_UNKNOWN_GOAL_ID: Final = 2
CANCEL_ERROR_GOAL_TERMINATED: Final = 3
CANCEL_CODES: Final = {0: "ERROR_NONE", 1: "ERROR_REJECTED", 2: "ERROR_UNKNOWN_GOAL_ID", 3: "ERROR_GOAL_TERMINATED"}

#: Nav2 Jazzy's error codes, which NavigateToPose's result carries from the task server that failed (the bt_navigator
#: passes on the failing node's ``error_code``): each action's .action file at the commit above.
NAV2_ERRORS: Final = {
    100: "FollowPath: unknown", 101: "FollowPath: invalid controller", 102: "FollowPath: TF error",
    103: "FollowPath: invalid path", 104: "FollowPath: patience exceeded",
    105: "FollowPath: failed to make progress", 106: "FollowPath: no valid control",
    107: "FollowPath: controller timed out",
    200: "ComputePathToPose: unknown", 201: "ComputePathToPose: invalid planner", 202: "ComputePathToPose: TF error",
    203: "ComputePathToPose: start outside the map", 204: "ComputePathToPose: goal outside the map",
    205: "ComputePathToPose: start occupied", 206: "ComputePathToPose: goal occupied",
    207: "ComputePathToPose: timeout", 208: "ComputePathToPose: no valid path",
    500: "SmoothPath: unknown", 501: "SmoothPath: invalid smoother", 502: "SmoothPath: timeout",
    503: "SmoothPath: smoothed path in collision", 504: "SmoothPath: failed to smooth path",
    505: "SmoothPath: invalid path",
    700: "Spin: unknown", 701: "Spin: timeout", 702: "Spin: TF error", 703: "Spin: collision ahead",
    710: "BackUp: unknown", 711: "BackUp: timeout", 712: "BackUp: TF error", 713: "BackUp: invalid input",
    714: "BackUp: collision ahead",
    720: "DriveOnHeading: unknown", 721: "DriveOnHeading: timeout", 722: "DriveOnHeading: TF error",
    723: "DriveOnHeading: collision ahead", 724: "DriveOnHeading: invalid input",
}  # fmt: skip

#: The 16 zero bytes of a goal id that means "every goal" in a CancelGoal request.
ALL_GOALS: Final = bytes(16)


def register(store: Any) -> Any:
    """Add NavigateToPose's and CancelGoal's types to ``store`` (those it lacks); returns it."""
    types = action_types(NAVIGATE_TO_POSE, NAVIGATE_TO_POSE_ACTION) | service_types(CANCEL_GOAL, CANCEL_GOAL_SRV)
    store.register({name: definition for name, definition in types.items() if name not in store.types})
    return store


def typestore() -> Any:
    """The project's type store (``relay.ros.ros_env.typestore``) with Nav2's action types and control_msgs'
    GripperCommand (relay/ros/control_types.py) registered."""
    from .ros_env import typestore as project_typestore

    return control_types.register(register(project_typestore()))


# -- what the relay reads -------------------------------------------------------------------------


def _seconds(t: Any) -> float:
    return float(t.sec) + float(t.nanosec) * 1e-9


def _uuid(goal_id: Any) -> bytes:
    return bytes(bytearray(int(b) for b in goal_id.uuid))


@dataclass(frozen=True, slots=True)
class GoalState:
    """One goal of a GoalStatusArray: its id (16 bytes), when the server accepted it (its clock) and its status."""

    goal_id: bytes
    accepted: float
    status: int


@dataclass(frozen=True, slots=True)
class Feedback:
    """NavigateToPose's feedback for one goal: metres, seconds, a count."""

    goal_id: bytes
    distance_remaining: float
    eta: float  # estimated_time_remaining
    recoveries: int  # number_of_recoveries
    navigation_time: float


@dataclass(frozen=True, slots=True)
class CancelAnswer:
    return_code: int
    goals_canceling: tuple[bytes, ...]

    @property
    def code_name(self) -> str:
        return CANCEL_CODES.get(self.return_code, f"return code {self.return_code}")


@dataclass(frozen=True, slots=True)
class ResultAnswer:
    """A GetResult response: the goal's final status and Nav2's error code and message."""

    status: int
    error_code: int
    error_msg: str


def read_status(data: bytes, decode: Decode) -> tuple[GoalState, ...]:
    message = decode(data, STATUS_ARRAY)
    return tuple(
        GoalState(_uuid(s.goal_info.goal_id), _seconds(s.goal_info.stamp), int(s.status)) for s in message.status_list
    )


def read_feedback(data: bytes, decode: Decode) -> Feedback:
    message = decode(data, FEEDBACK_MESSAGE)
    f = message.feedback
    distance, eta = float(f.distance_remaining), _seconds(f.estimated_time_remaining)
    return Feedback(
        _uuid(message.goal_id),
        distance if math.isfinite(distance) else -1.0,
        eta,
        int(f.number_of_recoveries),
        _seconds(f.navigation_time),
    )


def read_cancel_response(data: bytes, decode: Decode) -> CancelAnswer:
    message = decode(data, CANCEL_RESPONSE)
    return CancelAnswer(int(message.return_code), tuple(_uuid(g.goal_id) for g in message.goals_canceling))


def read_result_response(data: bytes, decode: Decode) -> ResultAnswer:
    message = decode(data, GET_RESULT_RESPONSE)
    return ResultAnswer(int(message.status), int(message.result.error_code), str(message.result.error_msg))


# -- what the relay writes ------------------------------------------------------------------------


def cancel_request(store: Any, goal_id: bytes = ALL_GOALS, stamp: float = 0.0) -> bytes:
    """A CancelGoal request's CDR; the defaults (zero id, zero stamp) cancel every goal of the server."""
    t = store.types
    sec = int(stamp)
    info = t["action_msgs/msg/GoalInfo"](
        goal_id=goal_id_message(store, goal_id),
        stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=int((stamp - sec) * 1e9)),
    )
    return bytes(store.serialize_cdr(t[CANCEL_REQUEST](goal_info=info), CANCEL_REQUEST))


def get_result_request(store: Any, goal_id: bytes) -> bytes:
    t = store.types
    request = t[GET_RESULT_REQUEST](goal_id=goal_id_message(store, goal_id))
    return bytes(store.serialize_cdr(request, GET_RESULT_REQUEST))


def failure_reason(error_code: int, error_msg: str) -> str:
    """Nav2's reason for an aborted goal, in words: its message, and the code's name when it is one of Nav2's."""
    name = NAV2_ERRORS.get(error_code)
    code = f"error {error_code}" + (f" ({name})" if name else "")
    if error_msg and error_code:
        return f"{error_msg} [{code}]"
    return error_msg or (code if error_code else "Nav2 aborted the goal")
