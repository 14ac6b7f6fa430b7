"""rosidl's split of actions and services into messages, for rosbags' type store: an action ``A`` becomes the
messages ``A_Goal``, ``A_Result``, ``A_Feedback``, the services ``A_SendGoal`` (``goal_id`` + goal -> ``accepted`` +
``stamp``) and ``A_GetResult`` (``goal_id`` -> ``status`` + result), and the feedback topic's ``A_FeedbackMessage``
(``goal_id`` + feedback); a service ``S`` becomes ``S_Request`` and ``S_Response``. Made from the definitions' text, so
the RIHS01 hashes rosbags computes are those of the definitions. Used for Nav2's action (relay/ros/nav2_types.py) and
ros2_control's (relay/ros/control_types.py). No I/O.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

#: ``decode(data, type_name)``: the message (rosbags), or ValueError naming the type (relay.backends.ingest.RawDecoder).
Decode = Callable[[bytes, str], Any]

Typesdict = dict[str, Any]


def _parts(text: str, count: int, what: str) -> list[str]:
    parts: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            parts.append([])
        else:
            parts[-1].append(line)
    if len(parts) != count:
        raise ValueError(f"{what}: expected {count} parts separated by '---', got {len(parts)}")
    return ["\n".join(part) + "\n" for part in parts]


def message_type(text: str, name: str) -> Typesdict:
    from rosbags.typesys import get_types_from_msg

    # rosbags files a name whose folder is neither msg nor action under msg (action_msgs/srv/msg/...): the definition
    # is the same, its name is put back.
    (definition,) = get_types_from_msg(text, name).values()
    return {name: definition}


def action_types(name: str, text: str) -> Typesdict:
    """The messages rosidl makes of the action ``name`` (``pkg/action/Name``) defined by ``text``."""
    goal, result, feedback = _parts(text, 3, name)
    types: Typesdict = {}
    types |= message_type(goal, f"{name}_Goal")
    types |= message_type(result, f"{name}_Result")
    types |= message_type(feedback, f"{name}_Feedback")
    uuid = "unique_identifier_msgs/UUID goal_id\n"
    types |= message_type(f"{uuid}{name}_Goal goal\n", f"{name}_SendGoal_Request")
    types |= message_type("bool accepted\nbuiltin_interfaces/Time stamp\n", f"{name}_SendGoal_Response")
    types |= message_type(uuid, f"{name}_GetResult_Request")
    types |= message_type(f"int8 status\n{name}_Result result\n", f"{name}_GetResult_Response")
    types |= message_type(f"{uuid}{name}_Feedback feedback\n", f"{name}_FeedbackMessage")
    return types


def service_types(name: str, text: str) -> Typesdict:
    """The request and response of the service ``name`` (``pkg/srv/Name``) defined by ``text``."""
    request, response = _parts(text, 2, name)
    return message_type(request, f"{name}_Request") | message_type(response, f"{name}_Response")


def goal_id_message(store: Any, goal_id: bytes) -> Any:
    import numpy as np

    if len(goal_id) != 16:
        raise ValueError(f"a goal id is 16 bytes, not {len(goal_id)}")
    return store.types["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(goal_id, dtype=np.uint8).copy())
