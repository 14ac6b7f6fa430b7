"""Nav2's action types in rosbags' type store (relay/ros/nav2_types.py): the relay reads what Nav2 writes.

The reference here is independent of the module: Nav2 Jazzy's own NavigateToPose.action, split by hand as rosidl
splits an action, registered in a type store of its own; CDR bytes written from it must read back as the feedback,
the result and the status the relay reports. CancelGoal's hashes are checked against the ROS installation's own.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from relay.backends.ingest import RawDecoder
from relay.ros import idl_types, nav2_types
from relay.ros.nav2_types import (
    CANCEL_RESPONSE,
    FEEDBACK_MESSAGE,
    GET_RESULT_RESPONSE,
    STATUS_ABORTED,
    STATUS_ARRAY,
    STATUS_EXECUTING,
    Feedback,
    GoalState,
    ResultAnswer,
)
from tests.helpers.nav2 import nav2_store

GOAL_ID = bytes(range(1, 17))


def test_feedback_written_from_nav2s_own_definition_reads_back_field_by_field() -> None:
    store = nav2_store()
    t = store.types
    duration = t["builtin_interfaces/msg/Duration"]
    pose = t["geometry_msgs/msg/PoseStamped"](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=5, nanosec=0), frame_id="map"),
        pose=t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        ),
    )
    feedback = t["nav2_msgs/action/NavigateToPose_Feedback"](
        current_pose=pose,
        navigation_time=duration(sec=12, nanosec=250_000_000),
        estimated_time_remaining=duration(sec=7, nanosec=500_000_000),
        number_of_recoveries=2,
        distance_remaining=3.25,
    )
    message = t[FEEDBACK_MESSAGE](
        goal_id=t["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(GOAL_ID, dtype=np.uint8).copy()),
        feedback=feedback,
    )
    data = bytes(store.serialize_cdr(message, FEEDBACK_MESSAGE))
    assert nav2_types.read_feedback(data, RawDecoder()) == Feedback(GOAL_ID, 3.25, 7.5, 2, 12.25)
    # The same definitions, so the same RIHS01 hashes (what rmw_zenoh puts in a key).
    relay_store = nav2_types.typestore()
    for name in (FEEDBACK_MESSAGE, GET_RESULT_RESPONSE, "nav2_msgs/action/NavigateToPose_Goal"):
        assert relay_store.hash_rihs01(name) == store.hash_rihs01(name), name


def test_an_aborted_goals_result_and_the_status_array_read_back() -> None:
    store = nav2_store()
    t = store.types
    result = t["nav2_msgs/action/NavigateToPose_Result"](error_code=208, error_msg="no valid path to (9.0, 6.0)")
    data = bytes(store.serialize_cdr(t[GET_RESULT_RESPONSE](status=STATUS_ABORTED, result=result), GET_RESULT_RESPONSE))
    answer = nav2_types.read_result_response(data, RawDecoder())
    assert answer == ResultAnswer(STATUS_ABORTED, 208, "no valid path to (9.0, 6.0)")
    assert nav2_types.failure_reason(answer.error_code, answer.error_msg) == (
        "no valid path to (9.0, 6.0) [error 208 (ComputePathToPose: no valid path)]"
    )
    assert nav2_types.failure_reason(105, "") == "error 105 (FollowPath: failed to make progress)"
    assert nav2_types.failure_reason(0, "") == "Nav2 aborted the goal"

    uuid = t["unique_identifier_msgs/msg/UUID"]
    statuses = [
        t["action_msgs/msg/GoalStatus"](
            goal_info=t["action_msgs/msg/GoalInfo"](
                goal_id=uuid(uuid=np.frombuffer(goal, dtype=np.uint8).copy()),
                stamp=t["builtin_interfaces/msg/Time"](sec=100 + i, nanosec=500_000_000),
            ),
            status=status,
        )
        for i, (goal, status) in enumerate([(GOAL_ID, STATUS_ABORTED), (bytes(16), STATUS_EXECUTING)])
    ]
    data = bytes(store.serialize_cdr(t[STATUS_ARRAY](status_list=statuses), STATUS_ARRAY))
    assert nav2_types.read_status(data, RawDecoder()) == (
        GoalState(GOAL_ID, 100.5, STATUS_ABORTED),
        GoalState(bytes(16), 101.5, STATUS_EXECUTING),
    )


def test_cancel_goal_is_ros_own_and_its_request_cancels_every_goal() -> None:
    store = nav2_types.typestore()
    share = Path(sys.prefix) / "share" / "action_msgs" / "srv" / "CancelGoal.json"
    if not share.exists():
        pytest.skip(f"no ROS installation's action_msgs here ({share})")
    hashes = {h["type_name"]: h["hash_string"] for h in json.loads(share.read_text())["type_hashes"]}
    for name in (nav2_types.CANCEL_REQUEST, CANCEL_RESPONSE, "action_msgs/msg/GoalInfo"):
        assert store.hash_rihs01(name) == hashes[name], name
    request = store.deserialize_cdr(nav2_types.cancel_request(store), nav2_types.CANCEL_REQUEST)
    assert bytes(request.goal_info.goal_id.uuid) == bytes(16)
    assert (request.goal_info.stamp.sec, request.goal_info.stamp.nanosec) == (0, 0)
    t = store.types
    canceling = [t["action_msgs/msg/GoalInfo"](
        goal_id=t["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(GOAL_ID, dtype=np.uint8).copy()),
        stamp=t["builtin_interfaces/msg/Time"](sec=1, nanosec=0),
    )]  # fmt: skip
    data = bytes(store.serialize_cdr(t[CANCEL_RESPONSE](return_code=0, goals_canceling=canceling), CANCEL_RESPONSE))
    answer = nav2_types.read_cancel_response(data, RawDecoder())
    assert (answer.return_code, answer.goals_canceling, answer.code_name) == (0, (GOAL_ID,), "ERROR_NONE")
    request = store.deserialize_cdr(nav2_types.get_result_request(store, GOAL_ID), nav2_types.GET_RESULT_REQUEST)
    assert bytes(request.goal_id.uuid) == GOAL_ID


def test_bytes_that_are_not_the_message_are_an_error_naming_it() -> None:
    with pytest.raises(ValueError, match="NavigateToPose_FeedbackMessage"):
        nav2_types.read_feedback(b"\x00\x01\x00\x00\x01\x02", RawDecoder())
    with pytest.raises(ValueError, match="a goal id is 16 bytes, not 3"):
        nav2_types.get_result_request(nav2_types.typestore(), b"abc")
    with pytest.raises(ValueError, match="expected 3 parts"):
        idl_types.action_types("nav2_msgs/action/Broken", "int8 a\n---\nint8 b\n")
