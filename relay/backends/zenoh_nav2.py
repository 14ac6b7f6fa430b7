"""Nav2's action and the watchdog's gate over Zenoh: the transport of relay/backends/navigation.py for the ``zenoh``
backend, with CDR through rosbags (relay/ros/nav2_types.py) and rmw_zenoh's keys (relay/backends/zenoh_keys.py).

- **Topics** as every other: ``<action>/_action/status`` (transient local: the subscriber asks the publisher's cache,
  as for the map) and ``<action>/_action/feedback`` in, per robot with ``navigation: nav2``; the gate out (a
  publisher with a cache of one sample, so a watchdog that starts later gets the word: rmw_zenoh's transient local)
  and the watchdog's gate_state in (with history), per robot with a watchdog.
- **Services** are Zenoh queries (rmw_zenoh's ``ClientData::send_request``): a get on the service's key with the
  request's CDR as payload and rmw_zenoh's attachment (sequence number, source timestamp, the client's GID); the
  server replies on its own key with the response's CDR. The relay queries ``<domain>/<service>/*/*`` (any type
  name and hash: a Humble robot's ``TypeHashNotSupported`` too), which intersects the queryable's exact key
  ``<domain>/<service>/<pkg>::srv::dds_::<Name>_/<hash>``, and takes the first reply. Behind zenoh-bridge-ros2dds
  the key is the service's name.

Replies and samples arrive on Zenoh's threads: they are decoded there and cross to the loop through the backend's
``hop`` and ``arrive`` (its one crossing).
"""

from __future__ import annotations

import asyncio
import functools
import logging
import time
from collections.abc import Callable
from typing import Any, Protocol

from ..config import FleetConfig
from ..fleet.events import GateWord
from ..fleet.scan import RateCap
from ..ros.idl_types import Decode
from ..ros.nav2_types import (
    FEEDBACK_MESSAGE,
    STATUS_ARRAY,
    CancelAnswer,
    ResultAnswer,
    cancel_request,
    get_result_request,
    read_cancel_response,
    read_feedback,
    read_result_response,
    read_status,
)
from .navigation import Arrive
from .ros_nav2 import FEEDBACK_RATE, gate_word
from .zenoh_session import ZenohSettings
from .zenoh_topics import Reply

logger = logging.getLogger(__name__)

STRING = "std_msgs/msg/String"

Hop = Callable[[Callable[[], None]], None]
#: A session's query (relay/backends/zenoh_topics.py ``ZenohTopics.query``): service, request, reply, timeout.
Ask = Callable[[str, bytes, Reply, float], None]


class Subscribe(Protocol):
    def __call__(
        self, what: str, topic: str, type_name: str, handle: Callable[[bytes], None], *, history: bool = False
    ) -> Any: ...


class Publish(Protocol):
    def put(self, payload: bytes) -> None: ...

    def undeclare(self) -> None: ...


class ZenohNav2:
    """Nav2's action and the watchdogs' gates on a Zenoh session: the transport of relay/backends/navigation.py."""

    def __init__(self, config: FleetConfig, settings: ZenohSettings, hop: Hop, arrive: Arrive) -> None:
        self._config = config
        self._settings = settings
        self._hop = hop
        self._arrive = arrive
        self._feedback_cap = RateCap(FEEDBACK_RATE)
        self._ask: Ask | None = None
        self._store: Any = None
        self._decode: Decode | None = None
        self._gates: dict[str, Publish] = {}

    def declare(
        self,
        ask: Ask,
        store: Any,
        decode: Decode,
        subscribe: Subscribe,
        publisher: Callable[[str, str], Publish],
    ) -> list[Any]:
        """Worker thread: every subscriber and gate publisher of a session (``ask`` sends its queries); returns what
        to undeclare later."""
        self._ask, self._store, self._decode = ask, store, decode
        # rosbags builds each type's serializer on its first use (tens to hundreds of milliseconds on a loaded
        # machine): here, in the worker thread, not in the estop that sends the first cancel.
        cancel_request(store)
        get_result_request(store, bytes(16))
        store.serialize_cdr(store.types[STRING](data=""), STRING)
        entities: list[Any] = []
        for robot in self._config.robots:
            name = robot.name
            if robot.nav_interface == "nav2":
                action = robot.nav_action
                entities.append(
                    subscribe(
                        f"{name} Nav2 status", f"{action}/_action/status", STATUS_ARRAY,
                        functools.partial(self._on_status, name), history=True,
                    )
                )  # fmt: skip
                entities.append(
                    subscribe(
                        f"{name} Nav2 feedback", f"{action}/_action/feedback", FEEDBACK_MESSAGE,
                        functools.partial(self._on_feedback, name),
                    )
                )  # fmt: skip
            if robot.watchdog_topic is not None:
                self._gates[name] = publisher(robot.gate_topic, STRING)
                entities.append(
                    subscribe(
                        f"{name} gate_state", robot.gate_state_topic, STRING,
                        functools.partial(self._on_gate_state, name), history=True,
                    )
                )  # fmt: skip
        return entities

    def close(self) -> None:
        for gate in self._gates.values():
            gate.undeclare()
        self._gates, self._ask = {}, None

    # -- samples (Zenoh's threads) ----------------------------------------------------------------

    def _on_status(self, robot: str, data: bytes) -> None:
        assert self._decode is not None
        goals = read_status(data, self._decode)  # a ValueError is named once per key by the backend's subscriber
        self._arrive(lambda n: n.status(robot, goals))

    def _on_feedback(self, robot: str, data: bytes) -> None:
        assert self._decode is not None
        if not self._feedback_cap.allow(robot, time.monotonic()):
            return
        feedback = read_feedback(data, self._decode)
        self._arrive(lambda n: n.feedback(robot, feedback))

    def _on_gate_state(self, robot: str, data: bytes) -> None:
        assert self._decode is not None
        text = str(self._decode(data, STRING).data)
        word = gate_word(text)
        if word is None:
            raise ValueError(f"the watchdog's gate_state {text[:40]!r} is none of drive, hold, estop")
        self._arrive(lambda n: n.gate_state(robot, word))

    # -- the transport (loop thread) --------------------------------------------------------------

    def publish_gate(self, robot: str, word: GateWord) -> None:
        message = self._store.types[STRING](data=word)
        self._gates[robot].put(bytes(self._store.serialize_cdr(message, STRING)))

    def _query(self, service: str, payload: bytes, read: Callable[[bytes], Any], timeout: float) -> asyncio.Future[Any]:
        """Send the request now; the loop's future gets ``read(the first reply's payload)``."""
        answer: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        if self._ask is None:
            raise RuntimeError(f"no Zenoh session to ask {service}")

        def settle(value: Any) -> None:
            if not answer.done():
                answer.set_result(value)

        def on_reply(data: bytes | None, error: str | None) -> None:  # Zenoh's thread
            if data is None:
                logger.warning("%s answered with an error: %s", service, error)
                return
            try:
                value = read(data)
            except ValueError as exc:
                logger.warning("%s: %s", service, exc)
                value = None
            self._hop(lambda: settle(value))

        self._ask(service, payload, on_reply, timeout)
        return answer

    def request_cancel(self, robot: str) -> asyncio.Future[CancelAnswer | None]:
        assert self._decode is not None
        decode = self._decode
        service = f"{self._action(robot)}/_action/cancel_goal"
        return self._query(service, cancel_request(self._store), lambda d: read_cancel_response(d, decode), 1.0)

    def request_result(self, robot: str, goal_id: bytes) -> asyncio.Future[ResultAnswer | None] | None:
        assert self._decode is not None
        decode = self._decode
        service = f"{self._action(robot)}/_action/get_result"
        request = get_result_request(self._store, goal_id)
        return self._query(service, request, lambda d: read_result_response(d, decode), 1.0)

    def _action(self, robot: str) -> str:
        spec = self._config.robot(robot)
        assert spec is not None
        return spec.nav_action
