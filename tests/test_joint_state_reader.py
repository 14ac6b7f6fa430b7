"""An arm's sensor_msgs/JointState as the byte-receiving backends read it (relay/backends/raw_readers.py): the real
CDR of a JointState (rosbags' serializer) becomes the arm's event; bytes that are not one, or whose names and
positions disagree, are named in one warning and change nothing."""

from __future__ import annotations

from typing import Any

import numpy as np

from relay.backends.ingest import RawDecoder
from relay.backends.raw_readers import JOINT_STATE_TYPE, read_joint_state
from relay.fleet.events import Event, JointStateEvent
from relay.ros.ros_env import typestore

STORE = typestore()
T = STORE.types


def joint_state(names: list[str], positions: list[float], velocities: list[float]) -> bytes:
    stamp = T["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=500_000_000)
    message = T[JOINT_STATE_TYPE](
        header=T["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
        name=names,
        position=np.asarray(positions, dtype=np.float64),
        velocity=np.asarray(velocities, dtype=np.float64),
        effort=np.zeros(0, dtype=np.float64),
    )
    return bytes(STORE.serialize_cdr(message, JOINT_STATE_TYPE))


def read(data: bytes) -> tuple[list[Event], list[str]]:
    events: list[Event] = []
    warnings: list[str] = []

    def warn(text: str, *args: Any) -> None:
        warnings.append(text % args)

    read_joint_state("robot3", data, RawDecoder(), events.append, warn=warn)
    return events, warnings


def test_a_joint_state_becomes_the_arms_event() -> None:
    events, warnings = read(joint_state(["joint1", "joint2"], [0.25, -0.5], [0.0, 0.1]))
    assert warnings == []
    assert events == [JointStateEvent("robot3", 1_700_000_000.5, ("joint1", "joint2"), (0.25, -0.5), (0.0, 0.1))]
    events, _ = read(joint_state(["joint1"], [0.25], []))  # a driver that sends no velocities
    assert events == [JointStateEvent("robot3", 1_700_000_000.5, ("joint1",), (0.25,), ())]


def test_bytes_that_are_not_a_joint_state_or_disagree_are_named_and_change_nothing() -> None:
    for data, said in (
        (b"\x00\x01\x00\x00garbage", "robot3 joint_states: undecodable sensor_msgs/msg/JointState"),
        (joint_state(["joint1", "joint2"], [0.25], []), "robot3 joint_states: 2 names, 1 positions, 0 velocities"),
        (joint_state(["joint1"], [0.25], [0.0, 0.1]), "robot3 joint_states: 1 names, 1 positions, 2 velocities"),
    ):
        events, warnings = read(data)
        assert events == []
        assert len(warnings) == 1 and warnings[0].startswith(said), warnings
