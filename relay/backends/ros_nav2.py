"""Nav2's action and the watchdog's gate on the ``ros`` backend's node: the transport of relay/backends/navigation.py.

Per robot with ``navigation: nav2``: ``<action>/_action/status`` (action_msgs/GoalStatusArray, reliable, transient
local: rcl_action's own QoS) and a CancelGoal client on ``<action>/_action/cancel_goal``, which the PyPI wheels have
(action_msgs); with nav2_msgs importable (a sourced ROS), also ``<action>/_action/feedback`` and a GetResult client on
``<action>/_action/get_result``. Per robot with a watchdog: the gate (std_msgs/String, reliable, transient local)
out and the watchdog's gate_state in. Status and feedback are read raw (rosbags, relay/ros/nav2_types.py), as the
zenoh backend reads them.

Callbacks run on the executor thread: they decode into immutable snapshots and cross to the loop through the
backend's ``arrive`` (its one crossing, relay/backends/live.py). Requests are sent from the loop; rclpy completes
their futures on the executor thread, and the answer crosses through its ``hop``.
"""

from __future__ import annotations

import asyncio
import importlib
import logging
import time
from collections.abc import Callable
from typing import Any, TypeVar

from ..config import FleetConfig, Robot
from ..fleet.events import GateWord
from ..fleet.scan import RateCap
from ..ros.idl_types import Decode
from ..ros.nav2_types import ALL_GOALS, CancelAnswer, ResultAnswer, read_feedback, read_status
from .navigation import Arrive

T = TypeVar("T")

logger = logging.getLogger(__name__)

#: Nav2's feedback is read at most this often per robot (the bt_navigator publishes it every tick, up to 100 Hz).
FEEDBACK_RATE = 4.0
GATE_WORDS: tuple[GateWord, ...] = ("drive", "hold", "estop")

Hop = Callable[[Callable[[], None]], None]


def nav2_action() -> Any:
    """nav2_msgs' NavigateToPose, or None when nav2_msgs is not installed (the PyPI ROS wheels)."""
    try:
        return importlib.import_module("nav2_msgs.action").NavigateToPose
    except (ImportError, AttributeError):
        return None


def gate_word(text: str) -> GateWord | None:
    return next((w for w in GATE_WORDS if w == text), None)


class RosNav2:
    """The rclpy entities of Nav2's action and the gates, created on each (re)built node by :meth:`create`."""

    def __init__(self, config: FleetConfig, hop: Hop, arrive: Arrive, decode: Decode) -> None:
        self._config = config
        self._hop = hop
        self._arrive = arrive
        self._decode = decode
        self._feedback_cap = RateCap(FEEDBACK_RATE)
        self._cancel: dict[str, Any] = {}
        self._result: dict[str, Any] = {}
        self._gate: dict[str, Any] = {}
        self._classes: dict[str, Any] = {}
        self._action: Any = None

    def create(self, node: Any, messages: Callable[[str, str], Any], qos: Any) -> None:
        """Worker thread: subscriptions, clients and publishers of every robot on ``node``."""
        self._cancel, self._result, self._gate = {}, {}, {}
        nav2 = [r for r in self._config.robots if r.nav_interface == "nav2"]
        gated = [r for r in self._config.robots if r.watchdog_topic is not None]
        if nav2:
            self._classes["cancel"] = messages("action_msgs.srv", "CancelGoal")
            status_cls = messages("action_msgs.msg", "GoalStatusArray")
            self._action = nav2_action()
            if self._action is None:
                logger.info(
                    "nav2_msgs is not installed: Nav2's outcomes come from its action status and cancels go through "
                    "its cancel service; its feedback and error codes need nav2_msgs (a sourced ROS 2)"
                )
        latched = qos.QoSProfile(
            depth=10, reliability=qos.ReliabilityPolicy.RELIABLE, durability=qos.DurabilityPolicy.TRANSIENT_LOCAL
        )
        for robot in nav2:
            name, action = robot.name, robot.nav_action
            node.create_subscription(
                status_cls, f"{action}/_action/status", lambda d, r=name: self._on_status(r, d), latched, raw=True
            )
            self._cancel[name] = node.create_client(self._classes["cancel"], f"{action}/_action/cancel_goal")
            if self._action is not None:
                impl = self._action.Impl
                node.create_subscription(
                    impl.FeedbackMessage, f"{action}/_action/feedback", lambda d, r=name: self._on_feedback(r, d),
                    qos.QoSProfile(depth=10, reliability=qos.ReliabilityPolicy.RELIABLE), raw=True,
                )  # fmt: skip
                self._result[name] = node.create_client(impl.GetResultService, f"{action}/_action/get_result")
        if gated:
            string = self._classes["string"] = messages("std_msgs.msg", "String")
            one = qos.QoSProfile(
                depth=1, reliability=qos.ReliabilityPolicy.RELIABLE, durability=qos.DurabilityPolicy.TRANSIENT_LOCAL
            )
            for robot in gated:
                self._gate[robot.name] = node.create_publisher(string, robot.gate_topic, one)
                node.create_subscription(
                    string, robot.gate_state_topic, lambda m, r=robot.name: self._on_gate_state(r, m), one
                )

    # -- callbacks (executor thread) --------------------------------------------------------------

    def _on_status(self, robot: str, data: bytes) -> None:
        goals = self._read(robot, "status", read_status, data)
        if goals is not None:
            self._arrive(lambda n: n.status(robot, goals))

    def _on_feedback(self, robot: str, data: bytes) -> None:
        if not self._feedback_cap.allow(robot, time.monotonic()):
            return
        feedback = self._read(robot, "feedback", read_feedback, data)
        if feedback is not None:
            self._arrive(lambda n: n.feedback(robot, feedback))

    def _read(self, robot: str, what: str, reader: Callable[[bytes, Decode], T], data: bytes) -> T | None:
        """One Nav2 message read, or None with a warning that names the robot and the topic's kind."""
        try:
            return reader(data, self._decode)
        except ValueError as exc:
            logger.warning("%s: Nav2 %s: %s", robot, what, exc)
            return None

    def _on_gate_state(self, robot: str, message: Any) -> None:
        word = gate_word(str(message.data))
        if word is None:
            logger.warning(
                "%s: the watchdog's gate_state %r is none of drive, hold, estop: ignored", robot, message.data
            )
            return
        self._arrive(lambda n: n.gate_state(robot, word))

    # -- the transport (loop thread) --------------------------------------------------------------

    def publish_gate(self, robot: str, word: GateWord) -> None:
        message = self._classes["string"]()
        message.data = word
        self._gate[robot].publish(message)

    def _call(self, client: Any, request: Any, read: Callable[[Any], Any]) -> asyncio.Future[Any]:
        """Send ``request`` now; the loop's future gets ``read(response)`` (None when rclpy failed it)."""
        answer: asyncio.Future[Any] = asyncio.get_running_loop().create_future()

        def settle(value: Any) -> None:
            if not answer.done():
                answer.set_result(value)

        def done(future: Any) -> None:  # the executor thread, or the loop if it was already done
            try:
                value = read(future.result())
            except Exception as exc:  # a failed call, a response of another shape
                logger.warning("a Nav2 service call failed: %r", exc)
                value = None
            self._hop(lambda: settle(value))

        client.call_async(request).add_done_callback(done)
        return answer

    def request_cancel(self, robot: str) -> asyncio.Future[CancelAnswer | None]:
        request = self._classes["cancel"].Request()
        request.goal_info.goal_id.uuid = list(ALL_GOALS)  # every goal, whenever accepted (stamp 0)
        return self._call(
            self._cancel[robot],
            request,
            lambda r: CancelAnswer(
                int(r.return_code), tuple(bytes(bytearray(g.goal_id.uuid)) for g in r.goals_canceling)
            ),
        )

    def request_result(self, robot: str, goal_id: bytes) -> asyncio.Future[ResultAnswer | None] | None:
        client = self._result.get(robot)
        if client is None:
            return None
        request = self._action.Impl.GetResultService.Request()
        request.goal_id.uuid = list(goal_id)
        return self._call(
            client, request, lambda r: ResultAnswer(int(r.status), int(r.result.error_code), str(r.result.error_msg))
        )


def needed_messages(robots: tuple[Robot, ...]) -> list[tuple[str, str, str]]:
    """(module, class, who) of the message packages Nav2's action and the gates need (check_messages)."""
    needed = []
    if any(r.nav_interface == "nav2" for r in robots):
        needed += [
            ("action_msgs.msg", "GoalStatusArray", "Nav2's action status (navigation: nav2)"),
            ("action_msgs.srv", "CancelGoal", "Nav2's cancel (navigation: nav2)"),
        ]
    if any(r.watchdog_topic is not None for r in robots):
        needed.append(("std_msgs.msg", "String", "the watchdog's gate (cmd_vel.watchdog)"))
    return needed
