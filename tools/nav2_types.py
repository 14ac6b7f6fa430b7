"""Nav2's NavigateToPose action and action_msgs' CancelGoal service in a rosbags typestore: CDR and RIHS01 hashes
over Zenoh without a ROS install (rosbags knows messages only, and nav2_msgs is no wheel).

The fields are Nav2 Jazzy's ``nav2_msgs/action/NavigateToPose.action`` (result: ``uint16 error_code``, ``string
error_msg``) and action_msgs' ``srv/CancelGoal.srv``, expanded as rosidl expands an action and a service: Goal,
Result, Feedback, FeedbackMessage (goal_id, feedback), the SendGoal and GetResult services (Request, Response, the
Event that service introspection publishes, and the service type made of the three, whose hash rmw_zenoh puts in a
service's key), and the action type itself. tests/test_gate.py checks every hash against ROS's own generator
(rosidl_generator_type_description) run on Nav2's .action text.

Until relay/ros/nav2_types.py (the relay's side of #27) exists, the fake fleet's Zenoh navigator uses this one.
"""

from __future__ import annotations

from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ACTION = "nav2_msgs/action/NavigateToPose"
FEEDBACK_MESSAGE = f"{ACTION}_FeedbackMessage"
GET_RESULT = f"{ACTION}_GetResult"
CANCEL_GOAL = "action_msgs/srv/CancelGoal"
STATUS_ARRAY = "action_msgs/msg/GoalStatusArray"

_UUID = "unique_identifier_msgs/msg/UUID"
_EVENT_INFO = "service_msgs/msg/ServiceEventInfo"
#: (type, .msg text): names in the text are the final ones; rosbags' parser is given them as ``pkg/msg/Name``.
_MESSAGES: tuple[tuple[str, str], ...] = (
    (f"{ACTION}_Goal", "geometry_msgs/msg/PoseStamped pose\nstring behavior_tree"),
    (f"{ACTION}_Result", "uint16 NONE=0\nuint16 error_code\nstring error_msg"),
    (
        f"{ACTION}_Feedback",
        "geometry_msgs/msg/PoseStamped current_pose\nbuiltin_interfaces/msg/Duration navigation_time\n"
        "builtin_interfaces/msg/Duration estimated_time_remaining\nint16 number_of_recoveries\n"
        "float32 distance_remaining",
    ),
    (FEEDBACK_MESSAGE, f"{_UUID} goal_id\n{ACTION}_Feedback feedback"),
    (f"{ACTION}_SendGoal_Request", f"{_UUID} goal_id\n{ACTION}_Goal goal"),
    (f"{ACTION}_SendGoal_Response", "bool accepted\nbuiltin_interfaces/msg/Time stamp"),
    (f"{GET_RESULT}_Request", f"{_UUID} goal_id"),
    (f"{GET_RESULT}_Response", f"int8 status\n{ACTION}_Result result"),
    (f"{CANCEL_GOAL}_Request", "action_msgs/msg/GoalInfo goal_info"),
    (
        f"{CANCEL_GOAL}_Response",
        "int8 ERROR_NONE=0\nint8 ERROR_REJECTED=1\nint8 ERROR_UNKNOWN_GOAL_ID=2\nint8 ERROR_GOAL_TERMINATED=3\n"
        "int8 return_code\naction_msgs/msg/GoalInfo[] goals_canceling",
    ),
)
_SERVICES = (f"{ACTION}_SendGoal", GET_RESULT, CANCEL_GOAL)


def _definitions() -> list[tuple[str, str]]:
    out = list(_MESSAGES)
    for service in _SERVICES:
        # What rosidl adds for each service: the introspection Event, and the service as a type of its own.
        out.append(
            (
                f"{service}_Event",
                f"service_msgs/msg/ServiceEventInfo info\n{service}_Request[<=1] request\n"
                f"{service}_Response[<=1] response",
            )
        )
        out.append(
            (
                service,
                f"{service}_Request request_message\n{service}_Response response_message\n"
                f"{service}_Event event_message",
            )
        )
    out.append(
        (
            ACTION,
            f"{ACTION}_Goal goal\n{ACTION}_Result result\n{ACTION}_Feedback feedback\n"
            f"{ACTION}_SendGoal send_goal_service\n{GET_RESULT} get_result_service\n"
            f"{FEEDBACK_MESSAGE} feedback_message",
        )
    )
    return out


def _as_msg(name: str) -> str:
    """``pkg/action/Name`` or ``pkg/srv/Name`` as the ``pkg/msg/Name`` rosbags' .msg parser insists on."""
    package, _, rest = name.split("/", 2)
    return f"{package}/msg/{rest}"


def _renamed(value: Any, names: dict[str, str]) -> Any:
    if isinstance(value, str):
        return names.get(value, value)
    if isinstance(value, tuple):
        return tuple(_renamed(v, names) for v in value)
    if isinstance(value, list):
        return [_renamed(v, names) for v in value]
    return value


def typestore() -> Any:
    """rosbags' LATEST types and these, with service_msgs/ServiceEventInfo's ``client_gid`` as rosidl reads it.

    The .msg says ``char[16]``; rosidl maps a .msg ``char`` to uint8, rosbags keeps it a char: the same bytes in CDR,
    but another type description, so rosbags' RIHS01 hash of every service (whose Event holds a ServiceEventInfo)
    differs from ROS's, and an rmw_zenoh client would not find the service's key."""
    latest = get_typestore(Stores.LATEST)
    definitions: dict[str, Any] = dict(latest.fielddefs)
    consts, fields = definitions[_EVENT_INFO]
    uint8_16 = (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16))
    definitions[_EVENT_INFO] = (consts, [(n, uint8_16 if n == "client_gid" else t) for n, t in fields])
    store = get_typestore(Stores.EMPTY)
    store.register(definitions)
    register(store)
    return store


def register(store: Any) -> None:
    """Adds the types to ``store`` (a rosbags Typestore); registering twice changes nothing."""
    definitions = _definitions()
    names = {_as_msg(name): name for name, _ in definitions}
    parsed: dict[str, Any] = {}
    for name, text in definitions:
        for full in names.values():
            text = text.replace(f"{full} ", f"{_as_msg(full)} ").replace(f"{full}[", f"{_as_msg(full)}[")
        parsed.update(get_types_from_msg(text, _as_msg(name)))
    store.register({names.get(key, key): _renamed(value, names) for key, value in parsed.items()})
