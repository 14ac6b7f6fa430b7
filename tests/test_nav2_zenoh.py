"""Nav2 over Zenoh: the zenoh backend follows a goal through Nav2's action on rmw_zenoh's keys (status and feedback
in, CancelGoal and GetResult as queries) and speaks the watchdog's gate, through a real Zenoh router on loopback.

The navigator is this file's, on the router's session, written from rmw_zenoh's source (keys, attachment,
services as queryables that reply on their own key) and from Nav2 Jazzy's definitions registered apart from the
relay (tests/test_nav2_types.py), not from relay/backends/zenoh_*.py.
"""

from __future__ import annotations

import asyncio
import struct
import threading
import time
import uuid
from collections.abc import AsyncIterator
from typing import Any

import numpy as np
import pytest

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")
ext = pytest.importorskip("zenoh.ext")

from relay.cli.options import Options, ZenohOptions  # noqa: E402
from relay.config import parse_config  # noqa: E402
from tests.conftest import RunningRelay, start_relay  # noqa: E402
from tests.helpers.nav2 import nav2_store  # noqa: E402
from tests.helpers.zenoh import Router, until  # noqa: E402
from tests.wsclient import TestClient  # noqa: E402
from tests.zenoh_robots import attachment  # noqa: E402

FLEET = """
safety: {deadman_timeout: 0.5, offline_after: 2.0}
zenoh: {domain_id: 0}
robots:
  - {name: alpha, limits: {linear: 0.5, angular: 1.0}, scan: null, plan: null, cmd_vel: {watchdog: true}}
"""

# action_msgs/srv/CancelGoal.srv and NavigateToPose's GetResult request, named by this test (rosidl's split).
SERVICES = {
    "nav2_msgs/action/NavigateToPose_GetResult_Request": "unique_identifier_msgs/UUID goal_id\n",
    "action_msgs/srv/CancelGoal_Request": "action_msgs/GoalInfo goal_info\n",
    "action_msgs/srv/CancelGoal_Response": (
        "int8 ERROR_NONE=0\nint8 return_code\naction_msgs/GoalInfo[] goals_canceling\n"
    ),
}
#: The RIHS01 of action_msgs/srv/CancelGoal as the ROS installation has it (share/action_msgs/srv/CancelGoal.json).
CANCEL_HASH = "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a"
FEEDBACK = "nav2_msgs/action/NavigateToPose_FeedbackMessage"


def robot_store() -> Any:
    from rosbags.typesys import get_types_from_msg

    store = nav2_store()
    for name, text in SERVICES.items():
        (definition,) = get_types_from_msg(text, name).values()
        store.register({name: definition})
    return store


STORE = robot_store()
T = STORE.types


def uuid_of(goal: bytes) -> Any:
    return T["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(goal, dtype=np.uint8).copy())


class Navigator:
    """alpha's Nav2 and watchdog on the router's session, driven by the test."""

    def __init__(self, session: Any, *, serve_cancel: bool = True) -> None:
        self.session = session
        self.goals: list[tuple[float, bytes]] = []  # goal_pose samples: (time, CDR)
        self.words: list[tuple[float, str, bytes | None]] = []  # gate words: (time, word, attachment)
        self.cancels: list[tuple[bytes, bytes | None]] = []  # cancel requests: (CDR, attachment)
        self.results: list[bytes] = []  # get_result requests
        self.statuses: dict[bytes, int] = {}
        self.result = (6, 208, "no valid path to the goal")
        self._lock = threading.Lock()
        # The status publisher is put to from zenoh's callback threads (a cancel answered) and undeclared by the
        # test's: one at a time (zenoh-python raised "Already borrowed" on an undeclare during a put), none after.
        self._publishing = threading.Lock()
        self._closed = False
        action = "0/alpha/navigate_to_pose/_action"
        self.status_pub = ext.declare_advanced_publisher(
            session,
            f"{action}/status/action_msgs::msg::dds_::GoalStatusArray_/{STORE.hash_rihs01('action_msgs/msg/GoalStatusArray')}",
            cache=ext.CacheConfig(max_samples=1),
            publisher_detection=True,
        )
        self.feedback_key = (
            f"{action}/feedback/nav2_msgs::action::dds_::NavigateToPose_FeedbackMessage_/{STORE.hash_rihs01(FEEDBACK)}"
        )
        self.entities = [
            session.declare_subscriber("0/alpha/goal_pose/*/*", self._goal),
            # The watchdog's reader of a transient-local topic: it asks the publishers' caches too (a word put
            # before this reader was known to the relay's session is not lost).
            ext.declare_advanced_subscriber(
                session, "0/alpha/xr_relay/gate/*/*", self._word, history=ext.HistoryConfig(detect_late_publishers=True)
            ),
            # A Humble robot's key: rmw_zenoh puts "TypeHashNotSupported" where the hash goes.
            session.declare_queryable(
                f"{action}/get_result/nav2_msgs::action::dds_::NavigateToPose_GetResult_/TypeHashNotSupported",
                self._get_result, complete=True,
            ),
        ]  # fmt: skip
        if serve_cancel:
            self.cancel_key = f"{action}/cancel_goal/action_msgs::srv::dds_::CancelGoal_/{CANCEL_HASH}"
            self.entities.append(session.declare_queryable(self.cancel_key, self._cancel, complete=True))

    def _goal(self, sample: Any) -> None:
        with self._lock:
            self.goals.append((time.monotonic(), sample.payload.to_bytes()))

    def _word(self, sample: Any) -> None:
        word = STORE.deserialize_cdr(sample.payload.to_bytes(), "std_msgs/msg/String").data
        extra = sample.attachment.to_bytes() if sample.attachment is not None else None
        with self._lock:
            self.words.append((time.monotonic(), word, extra))

    def _cancel(self, query: Any) -> None:
        request = query.payload.to_bytes()
        extra = query.attachment.to_bytes() if query.attachment is not None else None
        message = STORE.deserialize_cdr(request, "action_msgs/srv/CancelGoal_Request")
        everything = bytes(message.goal_info.goal_id.uuid) == bytes(16) and message.goal_info.stamp.sec == 0
        with self._lock:
            self.cancels.append((request, extra))
            cancelled = [g for g, s in self.statuses.items() if s == 2 and everything]
            for goal in cancelled:
                self.statuses[goal] = 5  # CANCELED
        infos = [
            T["action_msgs/msg/GoalInfo"](goal_id=uuid_of(g), stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0))
            for g in cancelled
        ]
        response = T["action_msgs/srv/CancelGoal_Response"](return_code=0 if infos else 1, goals_canceling=infos)
        # The reply carries the request's sequence number back, on the service's own key (ServiceData).
        sequence = struct.unpack_from("<q", extra)[0] if extra else 0
        reply_attachment = struct.pack("<qqB", sequence, time.time_ns(), 16) + b"S" * 16
        query.reply(self.cancel_key, bytes(STORE.serialize_cdr(response, "action_msgs/srv/CancelGoal_Response")),
                    attachment=reply_attachment)  # fmt: skip
        self.publish()

    def _get_result(self, query: Any) -> None:
        request = STORE.deserialize_cdr(query.payload.to_bytes(), "nav2_msgs/action/NavigateToPose_GetResult_Request")
        with self._lock:
            self.results.append(bytes(request.goal_id.uuid))
        status, code, text = self.result
        result = T["nav2_msgs/action/NavigateToPose_Result"](error_code=code, error_msg=text)
        response = T["nav2_msgs/action/NavigateToPose_GetResult_Response"](status=status, result=result)
        data = bytes(STORE.serialize_cdr(response, "nav2_msgs/action/NavigateToPose_GetResult_Response"))
        query.reply(str(query.key_expr), data, attachment=attachment(1))

    def set(self, goal: bytes, status: int) -> None:
        with self._lock:
            self.statuses[goal] = status
        self.publish()

    def publish(self) -> None:
        with self._lock:
            statuses = list(self.statuses.items())
        array = T["action_msgs/msg/GoalStatusArray"](
            status_list=[
                T["action_msgs/msg/GoalStatus"](
                    goal_info=T["action_msgs/msg/GoalInfo"](
                        goal_id=uuid_of(g), stamp=T["builtin_interfaces/msg/Time"](sec=100 + i, nanosec=0)
                    ),
                    status=s,
                )
                for i, (g, s) in enumerate(statuses)
            ]
        )
        data = bytes(STORE.serialize_cdr(array, "action_msgs/msg/GoalStatusArray"))
        with self._publishing:
            if not self._closed:
                self.status_pub.put(data, attachment=attachment(1))

    def feedback(self, goal: bytes, distance: float, eta: float, recoveries: int, spent: float) -> None:
        duration = T["builtin_interfaces/msg/Duration"]
        pose = T["geometry_msgs/msg/PoseStamped"](
            header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="map"),
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
            ),
        )
        feedback = T["nav2_msgs/action/NavigateToPose_Feedback"](
            current_pose=pose, navigation_time=duration(sec=int(spent), nanosec=int(spent % 1 * 1e9)),
            estimated_time_remaining=duration(sec=int(eta), nanosec=int(eta % 1 * 1e9)),
            number_of_recoveries=recoveries, distance_remaining=distance,
        )  # fmt: skip
        message = T[FEEDBACK](goal_id=uuid_of(goal), feedback=feedback)
        self.session.put(self.feedback_key, bytes(STORE.serialize_cdr(message, FEEDBACK)), attachment=attachment(1))

    def gate_words(self) -> list[str]:
        with self._lock:
            return [word for _, word, _ in self.words]

    def close(self) -> None:
        for entity in self.entities:
            entity.undeclare()
        with self._publishing:
            self._closed = True
            self.status_pub.undeclare()


@pytest.fixture
async def relay(router: Router) -> AsyncIterator[RunningRelay]:
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,), relay_id="A"))
    running = await start_relay(parse_config(FLEET, "fleet.yaml"), options=options)
    try:
        yield running
    finally:
        await running.runner.cleanup()


def nav(outcome: str, **fields: Any) -> Any:
    return lambda m: (
        m["identifier"] == "alpha/nav" and m["outcome"] == outcome and all(m[k] == v for k, v in fields.items())
    )


async def goal(client: TestClient, navigator: Navigator, x: float, y: float) -> bytes:
    """Send a goal until the navigator has it (the relay's subscriptions reach the router a moment after it
    started), then list it as a new NavigateToPose goal, executing; its id."""
    for _ in range(20):
        count = len(navigator.goals)
        assert (await client.request({"identifier": "alpha/goal_pose", "x": x, "y": y}))["identifier"] == "ack"
        try:
            await until(lambda c=count: len(navigator.goals) > c, 1.0, "the goal")
            break
        except AssertionError:
            continue
    goal_id = uuid.uuid4().bytes
    await asyncio.to_thread(navigator.set, goal_id, 2)  # EXECUTING
    return goal_id


async def test_feedback_outcomes_and_cancels_over_rmw_zenohs_keys(
    router: Router,
    relay: RunningRelay,
) -> None:
    navigator = await asyncio.to_thread(Navigator, router.session)  # rosbags builds its serializers: off the loop
    client = await TestClient.open(relay.ws_url)
    try:
        await client.hello()
        # A goal: Nav2's feedback while it runs (decoded from Nav2's own definition), then its success.
        first = await goal(client, navigator, 2.0, 3.0)
        feedback = await client.wait_for(nav("started", goal={"x": 2.0, "y": 3.0, "yaw": None}), timeout=5)
        deadline = time.monotonic() + 5
        while feedback["feedback"] is None and time.monotonic() < deadline:
            await asyncio.to_thread(navigator.feedback, first, 3.25, 7.5, 1, 12.25)
            await asyncio.sleep(0.3)
            feedback = client.latest["alpha/nav"]
        assert feedback["feedback"] == {
            "distance_remaining": 3.25,
            "eta": 7.5,
            "recoveries": 1,
            "navigation_time": 12.2,
        }
        await asyncio.to_thread(navigator.set, first, 4)  # SUCCEEDED
        reached = await client.wait_for(nav("reached"), timeout=5)
        assert reached["goal"] == {"x": 2.0, "y": 3.0, "yaw": None}
        words = await until(navigator.gate_words, 5, "a gate word")
        assert words[0] == "drive"
        _, _, extra = navigator.words[0]
        assert extra is not None and len(extra) == 33  # rmw_zenoh's attachment on the gate too

        # An unreachable goal: aborted, the reason asked with GetResult (a query), reported within a second.
        start = len(client.messages)
        second = await goal(client, navigator, -1.0, 3.0)
        await asyncio.sleep(0.2)
        aborted_at = time.monotonic()
        await asyncio.to_thread(navigator.set, second, 6)  # ABORTED
        failed = await client.wait_for(nav("failed"), start=start, timeout=5)
        assert next(t for t, m in client.messages if m is failed) - aborted_at < 1.0
        assert failed["error_code"] == 208 and "no valid path to the goal" in failed["message"]
        assert "ComputePathToPose: no valid path" in failed["message"]
        assert navigator.results == [second]

        # An estop: Nav2's cancel is a query with the request's CDR and rmw_zenoh's attachment, answered later.
        start = len(client.messages)
        third = await goal(client, navigator, 60.0, 2.0)
        await client.wait_for(lambda m: m["identifier"] == "alpha/status" and m["mode"] == "navigating", start=start)
        assert (await client.request({"identifier": "estop"}))["identifier"] == "ack"
        confirmed = await client.wait_for(nav("cancelled", confirmed=True), start=start, timeout=5)
        assert confirmed["goal"]["x"] == 60.0 and confirmed["message"] == "Nav2 is cancelling 1 goal"
        request, extra = navigator.cancels[-1]
        cancel = STORE.deserialize_cdr(request, "action_msgs/srv/CancelGoal_Request")
        assert bytes(cancel.goal_info.goal_id.uuid) == bytes(16) and cancel.goal_info.stamp.sec == 0
        assert extra is not None and len(extra) == 33 and struct.unpack_from("<qqB", extra)[2] == 16
        assert navigator.statuses[third] == 5
        await until(lambda: navigator.gate_words()[-1] == "estop", 5, "the gate's estop")
        assert (await client.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"
        await until(lambda: navigator.gate_words()[-1] == "drive", 5, "the gate's drive on reset")
    finally:
        await client.close()
        navigator.close()


async def test_a_latch_the_watchdog_holds_reaches_a_relay_started_later_and_an_unanswered_cancel_is_named(
    router: Router,
) -> None:
    # The watchdog latched before this relay started: its gate_state (with a cache, as rmw_zenoh's transient local).
    navigator = await asyncio.to_thread(lambda: Navigator(router.session, serve_cancel=False))
    state = ext.declare_advanced_publisher(
        router.session,
        f"0/alpha/xr_relay/gate_state/std_msgs::msg::dds_::String_/{STORE.hash_rihs01('std_msgs/msg/String')}",
        cache=ext.CacheConfig(max_samples=1),
        publisher_detection=True,
    )
    state.put(bytes(STORE.serialize_cdr(T["std_msgs/msg/String"](data="estop"), "std_msgs/msg/String")))
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,), relay_id="B"))
    running = await start_relay(parse_config(FLEET, "fleet.yaml"), options=options)
    client = await TestClient.open(running.ws_url)
    try:
        await client.hello()
        await until(lambda: running.relay.control.latched, 5, "the watchdog's latch")
        assert running.relay.control.latched == {"alpha": "the robot's watchdog"}
        reply = await client.request({"identifier": "alpha/goal_pose", "x": 1.0, "y": 1.0})
        assert reply["code"] == "estopped" and "the robot's watchdog" in reply["message"]
        assert set(navigator.gate_words()) <= {"estop"}  # nothing said lifted the latch
        assert (await client.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"
        await until(lambda: navigator.gate_words() and navigator.gate_words()[-1] == "drive", 5, "the reset's drive")
        # No navigator serves cancel_goal here: the operator learns it did not answer, a second after the cancel.
        start = len(client.messages)
        await goal(client, navigator, 60.0, 2.0)
        await client.wait_for(lambda m: m["identifier"] == "alpha/status" and m["mode"] == "navigating", start=start)
        sent = time.monotonic()
        assert (await client.request({"identifier": "alpha/cancel"}))["identifier"] == "ack"
        unanswered = await client.wait_for(nav("cancelled", confirmed=False), start=start, timeout=5)
        assert unanswered["message"] == "Nav2 did not answer the cancel within 1 s"
        assert 0.9 < next(t for t, m in client.messages if m is unanswered) - sent < 2.5
    finally:
        await client.close()
        await running.runner.cleanup()
        state.undeclare()
        navigator.close()
