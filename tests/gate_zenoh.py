"""A stand-in for the relay on a Zenoh network under rmw_zenoh's keys, for the gate's tests (tests/test_gate.py): the
relay's words to a robot (gate, heartbeat, teleop, goals, the action's services) and what the test watches.

Two sessions, clients of the fake fleet's router: the relay's (its publishers, the gate's with a cache as rmw_zenoh
makes a transient-local topic; closed when the relay dies) and the watcher's. Keys and attachments are spelled out
here (tests/zenoh_robots.py), not taken from the relay; the services' keys carry the hashes ROS's own generator gives
(``hashes``), and Nav2's messages are read with tools/nav2_types.py's types, whose hashes are checked against it.
"""

from __future__ import annotations

import itertools
import json
import threading
import time
from typing import Any

import numpy as np
import zenoh
import zenoh.ext

from relay.config import FleetConfig
from tests.gate_dds import Sample, wait_until
from tests.zenoh_robots import attachment

STRING, HEADER = "std_msgs/msg/String", "std_msgs/msg/Header"
TWIST, TWIST_STAMPED = "geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"
POSE_STAMPED, ODOMETRY = "geometry_msgs/msg/PoseStamped", "nav_msgs/msg/Odometry"
STATUS = "action_msgs/msg/GoalStatusArray"
FEEDBACK = "nav2_msgs/action/NavigateToPose_FeedbackMessage"
CANCEL, GET_RESULT = "action_msgs/srv/CancelGoal", "nav2_msgs/action/NavigateToPose_GetResult"


def client(endpoint: str) -> Any:
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    # A publisher with a cache (a transient-local topic: the gate) needs timestamps, which clients lack by default.
    config.insert_json5("timestamping/enabled", "true")
    return zenoh.open(config)


class ZenohRelay:
    def __init__(self, endpoint: str, config: FleetConfig, store: Any, hashes: dict[str, str]) -> None:
        self.config, self.store, self.hashes = config, store, hashes
        self.t = store.types
        self.session = client(endpoint)  # the relay's
        self.watcher = client(endpoint)
        self.lock = threading.Lock()
        self._sequence = itertools.count(1)
        self.cmd_vel: dict[str, list[Sample]] = {}
        self.autonomy: dict[str, list[Sample]] = {}
        self.poses: dict[str, list[tuple[float, float, float]]] = {}
        self.gate_states: dict[str, list[str]] = {}
        self.statuses: dict[str, list[tuple[bytes, int]]] = {}
        self.status_heard: set[str] = set()
        self.feedback: dict[str, list[Any]] = {}
        self._pubs: dict[str, Any] = {}
        self._entities: list[Any] = []
        for robot in config.robots:
            n = robot.name
            self.cmd_vel[n], self.autonomy[n], self.poses[n] = [], [], []
            self.gate_states[n], self.statuses[n], self.feedback[n] = [], [], []
            self._pubs[f"{n}/gate"] = zenoh.ext.declare_advanced_publisher(
                self.session, self.key(robot.gate_topic, STRING), cache=zenoh.ext.CacheConfig(max_samples=1),
                publisher_detection=True,
            )  # fmt: skip
            assert robot.watchdog_topic is not None
            self._pubs[f"{n}/teleop"] = self.session.declare_publisher(self.key(robot.watchdog_topic, TWIST_STAMPED))
            self._pubs[f"{n}/goal"] = self.session.declare_publisher(self.key(robot.goal_topic, POSE_STAMPED))
            action = robot.nav_action
            self._watch(robot.cmd_vel_topic, TWIST, lambda m, s=self.cmd_vel[n]: self._twist(s, m))
            self._watch(robot.autonomy_topic, TWIST, lambda m, s=self.autonomy[n]: self._twist(s, m))
            self._watch(robot.pose.topic, ODOMETRY, lambda m, s=self.poses[n]: self._pose(s, m))
            self._watch(f"{action}/_action/feedback", FEEDBACK, lambda m, s=self.feedback[n]: self._note(s, m))
            self._watch(robot.gate_state_topic, STRING, lambda m, s=self.gate_states[n]: self._note(s, m.data), True)
            self._watch(f"{action}/_action/status", STATUS, lambda m, r=n: self._status(r, m), True)
        self._heartbeat = self.session.declare_publisher(self.key(config.ros.heartbeat_topic, HEADER))
        self.heartbeat_on = True
        self._running = True
        self._beat = threading.Thread(target=self._beating, name="zenoh-relay-heartbeat", daemon=True)
        self._beat.start()

    def key(self, topic: str, type_name: str) -> str:
        """rmw_zenoh's ``<domain>/<topic>/<pkg>::<kind>::dds_::<Name>_/<RIHS01 hash>``."""
        package, kind, name = type_name.split("/")
        digest = self.hashes.get(type_name) or self.store.hash_rihs01(type_name)
        return f"0/{topic.strip('/')}/{package}::{kind}::dds_::{name}_/{digest}"

    # -- what the relay sends -----------------------------------------------------------------------

    def _put(self, publisher: Any, message: Any, type_name: str) -> None:
        publisher.put(bytes(self.store.serialize_cdr(message, type_name)), attachment=attachment(next(self._sequence)))

    def _header(self) -> Any:
        now = time.time()
        stamp = self.t["builtin_interfaces/msg/Time"](sec=int(now), nanosec=int((now - int(now)) * 1e9))
        return self.t[HEADER](stamp=stamp, frame_id="map")

    def gate(self, robot: str, word: str) -> None:
        self._put(self._pubs[f"{robot}/gate"], self.t[STRING](data=word), STRING)

    def teleop(self, robot: str, linear: float, angular: float = 0.0) -> None:
        vector = self.t["geometry_msgs/msg/Vector3"]
        twist = self.t[TWIST](linear=vector(x=linear, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=angular))
        self._put(
            self._pubs[f"{robot}/teleop"], self.t[TWIST_STAMPED](header=self._header(), twist=twist), TWIST_STAMPED
        )

    def goal(self, robot: str, x: float, y: float) -> bytes:
        # The goals known before this one: the status list must have been heard (a late joiner's history comes
        # asynchronously), or an old goal would pass for the new one.
        wait_until(lambda: robot in self.status_heard, 30, f"{robot}'s action status")
        with self.lock:
            known = {uuid for uuid, _ in self.statuses[robot]}
        pose = self.t["geometry_msgs/msg/Pose"](
            position=self.t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=self.t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        )
        self._put(self._pubs[f"{robot}/goal"], self.t[POSE_STAMPED](header=self._header(), pose=pose), POSE_STAMPED)

        def new() -> bytes | None:
            with self.lock:
                return next((uuid for uuid, _ in self.statuses[robot] if uuid not in known), None)

        uuid: bytes = wait_until(new, 10, f"{robot}'s new goal in the action's status")
        return uuid

    def call(self, robot: str, service: str, type_name: str, request: Any, timeout: float = 10.0) -> tuple[Any, bytes]:
        """One rmw_zenoh service call on the exact key: (the response, the reply's attachment)."""
        spec = self.config.robot(robot)
        assert spec is not None
        key = self.key(f"{spec.nav_action}/_action/{service}", type_name)
        payload = bytes(self.store.serialize_cdr(request, f"{type_name}_Request"))
        sent = attachment(next(self._sequence))
        replies = list(self.session.get(key, payload=payload, attachment=sent, timeout=timeout))
        assert len(replies) == 1 and replies[0].ok is not None, f"{service}: {replies}"
        reply = replies[0].ok
        assert str(reply.key_expr) == key
        response = self.store.deserialize_cdr(reply.payload.to_bytes(), f"{type_name}_Response")
        return response, reply.attachment.to_bytes()

    def cancel(self, robot: str, uuid: bytes = bytes(16)) -> Any:
        t = self.t
        info = t["action_msgs/msg/GoalInfo"](
            goal_id=t["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(uuid, np.uint8).copy()),
            stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
        )
        response, _ = self.call(robot, "cancel_goal", CANCEL, t[f"{CANCEL}_Request"](goal_info=info))
        return response

    def die(self) -> None:
        """The relay is gone: its session closed (the gate's publisher and cache, the heartbeat)."""
        self._running = False
        self._beat.join(2)
        self.session.close()

    # -- what the test watches ----------------------------------------------------------------------

    def status(self, robot: str, uuid: bytes) -> int | None:
        with self.lock:
            return next((s for u, s in self.statuses[robot] if u == uuid), None)

    def since(self, samples: list[Sample], start: float) -> list[Sample]:
        with self.lock:
            return [s for s in samples if s[0] >= start]

    def pose(self, robot: str) -> tuple[float, float]:
        wait_until(lambda: self.poses[robot], 30, f"{robot}'s pose")
        with self.lock:
            _, x, y = self.poses[robot][-1]
        return x, y

    def pose_at(self, robot: str, at: float) -> tuple[float, float]:
        with self.lock:
            _, x, y = next(p for p in self.poses[robot] if p[0] >= at)
        return x, y

    def late_gate_state(self, robot: str, timeout: float = 10.0) -> str:
        spec = self.config.robot(robot)
        assert spec is not None
        heard: list[str] = []
        subscriber = self._watch(spec.gate_state_topic, STRING, lambda m: self._note(heard, m.data), True)
        try:
            word: str = wait_until(lambda: heard[-1] if heard else None, timeout, f"{robot}'s gate_state")
            return word
        finally:
            subscriber.undeclare()

    def close(self) -> None:
        if self._running:
            self.die()
        self.watcher.close()

    # -- internals ------------------------------------------------------------------------------------

    def _watch(self, topic: str, type_name: str, handle: Any, history: bool = False) -> Any:
        selector = f"0/{topic.strip('/')}/*/*"

        def on_sample(sample: Any) -> None:
            handle(self.store.deserialize_cdr(sample.payload.to_bytes(), type_name))

        if history:
            subscriber = zenoh.ext.declare_advanced_subscriber(
                self.watcher, selector, on_sample, history=zenoh.ext.HistoryConfig(detect_late_publishers=True)
            )
        else:
            subscriber = self.watcher.declare_subscriber(selector, on_sample)
        self._entities.append(subscriber)
        return subscriber

    def _twist(self, samples: list[Sample], message: Any) -> None:
        with self.lock:
            samples.append((time.monotonic(), float(message.linear.x), float(message.angular.z)))

    def _pose(self, poses: list[tuple[float, float, float]], message: Any) -> None:
        p = message.pose.pose.position
        with self.lock:
            poses.append((time.monotonic(), float(p.x), float(p.y)))

    def _note(self, store: list[Any], value: Any) -> None:
        with self.lock:
            store.append(value)

    def _status(self, robot: str, message: Any) -> None:
        with self.lock:
            self.status_heard.add(robot)
            self.statuses[robot] = [(bytes(s.goal_info.goal_id.uuid), int(s.status)) for s in message.status_list]

    def _beating(self) -> None:
        while self._running:
            if self.heartbeat_on:
                self._put(self._heartbeat, self._header(), HEADER)
            time.sleep(0.1)
