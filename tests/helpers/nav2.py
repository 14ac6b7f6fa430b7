"""Nav2's NavigateToPose as Nav2 Jazzy writes it, in a rosbags type store of its own: what the relay's decoding is
checked against."""

from __future__ import annotations

from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

# ros-navigation/navigation2, branch jazzy, nav2_msgs/action/NavigateToPose.action (Apache-2.0), as released.
JAZZY_ACTION = """#goal definition
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


def nav2_store() -> Any:
    """A type store with NavigateToPose registered by this test, apart from relay.ros.nav2_types."""
    goal, result, feedback = JAZZY_ACTION.split("---\n")
    name = "nav2_msgs/action/NavigateToPose"
    types: dict[str, Any] = {}
    for text, part in (
        (goal, "Goal"),
        (result, "Result"),
        (feedback, "Feedback"),
        ("unique_identifier_msgs/UUID goal_id\nnav2_msgs/action/NavigateToPose_Feedback feedback\n", "FeedbackMessage"),
        ("int8 status\nnav2_msgs/action/NavigateToPose_Result result\n", "GetResult_Response"),
    ):
        types |= get_types_from_msg(text, f"{name}_{part}")
    store = get_typestore(Stores.LATEST)
    store.register(types)
    return store
