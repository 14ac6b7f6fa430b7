"""The fake fleet's robot side over Zenoh (``tools/fake_fleet.py --zenoh``): the watchdog as each robot's gate and,
with ``--nav2``, Nav2's interface, on rmw_zenoh's keys with its attachment, CDR through rosbags.

- ``ZenohWatchdogs``: ``relay/watchdog/node.py`` over Zenoh, with the same rules (``relay.watchdog.rules``): teleop,
  autonomy, the relay's gate (its publisher's cache read by history: transient local, as rmw_zenoh does it) and
  heartbeat in; the robot's ``cmd_vel`` (which the base follows) and ``gate_state`` (cached) out.
- ``ZenohNav2``: per robot the navigator of ``relay.sim.navigator``: goal_pose in; ``<action>/_action/status``
  (cached), ``<action>/_action/feedback`` and the controller's ``cmd_vel_nav`` out; ``cancel_goal`` and
  ``get_result`` as queryables on the services' keys (rmw_zenoh's: the service type, its RIHS01 hash), replied with
  the request's sequence number and client GID in the attachment; a result is replied when its goal ends.

Both are driven by the fleet's main loop (``tick``, ``step``) and called back from Zenoh's threads; one lock each
keeps a decision and its publication together, so that nothing is published out of order with a gate's change.
"""

from __future__ import annotations

import importlib
import logging
import threading
import time
import uuid as uuidlib
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from relay.backends.zenoh_keys import GID_SIZE, Attachment, decode_attachment, topic_key
from relay.config import Robot
from relay.fleet.geometry import quaternion_to_yaw, yaw_to_quaternion
from relay.sim import navigator as nav
from relay.sim.navigator import Navigator, world_planner
from relay.sim.world import SimWorld
from relay.watchdog.rules import WatchdogRules

logger = logging.getLogger("fake_fleet_zenoh.robots")

TWIST, TWIST_STAMPED = "geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"
STRING = "std_msgs/msg/String"


class Fleet(Protocol):
    """What the fleet lends these parts: its session, keys, publication, world and lock."""

    session: Any
    store: Any
    domain: int
    world: SimWorld
    lock: threading.Lock

    def key(self, topic: str, type_name: str) -> str: ...
    def selector(self, topic: str) -> str: ...
    def put(self, publisher: Any, message: Any, type_name: str) -> None: ...
    def header(self, frame: str) -> Any: ...


def _ext() -> Any:
    return importlib.import_module("zenoh.ext")


def _cached_publisher(session: Any, key: str) -> Any:
    """Transient local, as rmw_zenoh does it: a publisher's cache that a late subscriber's history query reads."""
    ext = _ext()
    return ext.declare_advanced_publisher(session, key, cache=ext.CacheConfig(max_samples=1), publisher_detection=True)


def _history_subscriber(session: Any, selector: str, handler: Any) -> Any:
    ext = _ext()
    return ext.declare_advanced_subscriber(
        session, selector, handler, history=ext.HistoryConfig(detect_late_publishers=True)
    )


def _twist(fleet: Fleet, robot: Robot, linear: float, angular: float) -> tuple[Any, str]:
    t = fleet.store.types
    vector = t["geometry_msgs/msg/Vector3"]
    twist = t[TWIST](linear=vector(x=float(linear), y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=float(angular)))
    if robot.cmd_vel_stamped:
        return t[TWIST_STAMPED](header=fleet.header(robot.pose.base_frame), twist=twist), TWIST_STAMPED
    return twist, TWIST


class ZenohWatchdogs:
    """The watchdogs of some robots, each the only publisher of its robot's cmd_vel."""

    def __init__(self, fleet: Fleet, robots: Sequence[Robot], timeout: float, heartbeat_topic: str) -> None:
        self._fleet = fleet
        self._lock = threading.Lock()
        self.rules: dict[str, WatchdogRules] = {}
        self._robots: dict[str, Robot] = {}
        self._cmd_vel: dict[str, Any] = {}
        self._gate_state: dict[str, Any] = {}
        self._entities: list[Any] = []
        self._dropping: dict[tuple[str, str], str] = {}
        session = fleet.session
        for robot in robots:
            assert robot.watchdog_topic is not None
            name = robot.name
            self.rules[name] = WatchdogRules(timeout, robot.on_relay_lost)
            self._robots[name] = robot
            twist_type = TWIST_STAMPED if robot.cmd_vel_stamped else TWIST
            self._cmd_vel[name] = session.declare_publisher(fleet.key(robot.cmd_vel_topic, twist_type))
            self._gate_state[name] = _cached_publisher(session, fleet.key(robot.gate_state_topic, STRING))
            self._entities += [
                session.declare_subscriber(fleet.selector(robot.watchdog_topic), lambda s, r=name: self._teleop(r, s)),
                session.declare_subscriber(
                    fleet.selector(robot.autonomy_topic), lambda s, r=name: self._autonomy(r, s)
                ),
                _history_subscriber(session, fleet.selector(robot.gate_topic), lambda s, r=name: self._gate(r, s)),
            ]
            self._publish_gate_state(name)
        self._entities.append(session.declare_subscriber(fleet.selector(heartbeat_topic), self._heartbeat))

    def _decode(self, robot: str, sample: Any, type_name: str) -> Any | None:
        try:
            return self._fleet.store.deserialize_cdr(sample.payload.to_bytes(), type_name)
        except Exception as exc:  # rosbags raises several kinds on bytes that are not the type
            logger.warning("%s: %s is not a %s: %.80s", robot, sample.key_expr, type_name, exc)
            return None

    def _heartbeat(self, _sample: Any) -> None:
        now = time.time()
        with self._lock:
            for rules in self.rules.values():
                rules.heartbeat(now)

    def _gate(self, robot: str, sample: Any) -> None:
        message = self._decode(robot, sample, STRING)
        if message is None:
            return
        with self._lock:
            rules = self.rules[robot]
            before = rules.gate
            try:
                reason = rules.set_gate(message.data, time.time())
            except ValueError as exc:
                logger.warning("%s: gate word ignored: %s", robot, exc)
                return
            if reason is not None:
                logger.warning("%s: stopped: %s", robot, reason)
                self._publish(robot, 0.0, 0.0)
            if rules.gate != before:
                logger.info("%s: gate %s -> %s", robot, before, rules.gate)
                self._publish_gate_state(robot)

    def _teleop(self, robot: str, sample: Any) -> None:
        message = self._decode(robot, sample, TWIST_STAMPED)
        if message is None:
            return
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        linear, angular = float(message.twist.linear.x), float(message.twist.angular.z)
        with self._lock:
            verdict = self.rules[robot].command(linear, angular, stamp, time.time())
            self._forward(robot, "teleop", linear, angular, verdict.forward, verdict.reason)

    def _autonomy(self, robot: str, sample: Any) -> None:
        stamped = self._robots[robot].cmd_vel_stamped
        message = self._decode(robot, sample, TWIST_STAMPED if stamped else TWIST)
        if message is None:
            return
        twist = message.twist if stamped else message
        linear, angular = float(twist.linear.x), float(twist.angular.z)
        with self._lock:
            verdict = self.rules[robot].autonomy(linear, angular, time.time())
            self._forward(robot, "autonomy", linear, angular, verdict.forward, verdict.reason)

    def _forward(self, robot: str, source: str, linear: float, angular: float, forward: bool, reason: str) -> None:
        if forward:
            self._dropping.pop((robot, source), None)
            self._publish(robot, linear, angular)
        elif self._dropping.get((robot, source)) != reason:
            self._dropping[(robot, source)] = reason  # once per reason: a held controller publishes 20 a second
            logger.warning("%s: %s not forwarded: %s", robot, source, reason)

    def tick(self, now: float) -> None:
        """Called by the fleet's loop, every 20 ms."""
        with self._lock:
            for robot, rules in self.rules.items():
                reason = rules.tick(now)
                if reason is not None:
                    if rules.gate != "estop":
                        logger.warning("%s: stopped: %s", robot, reason)
                    self._publish(robot, 0.0, 0.0)

    def _publish(self, robot: str, linear: float, angular: float) -> None:
        message, type_name = _twist(self._fleet, self._robots[robot], linear, angular)
        self._fleet.put(self._cmd_vel[robot], message, type_name)

    def _publish_gate_state(self, robot: str) -> None:
        message = self._fleet.store.types[STRING](data=self.rules[robot].gate)
        self._fleet.put(self._gate_state[robot], message, STRING)


class ZenohNav2:
    """Per robot, a navigator with Nav2's interface over Zenoh."""

    def __init__(self, fleet: Fleet, robots: Sequence[Robot], *, misbehave_after_cancel: bool = False) -> None:
        nav2_types = importlib.import_module("nav2_types")  # tools/, beside this file
        self._types = nav2_types
        self._fleet = fleet
        self.store = nav2_types.typestore()
        self._t = self.store.types
        self._lock = threading.Lock()
        self._gid = uuidlib.uuid4().bytes[:GID_SIZE]
        self._sequence = 0
        self.navigators: dict[str, Navigator] = {}
        self._robots: dict[str, Robot] = {}
        self._pubs: dict[tuple[str, str], Any] = {}
        self._entities: list[Any] = []
        self._waiting: dict[bytes, list[tuple[Any, str, Attachment]]] = {}  # get_result queries held till the end
        session = fleet.session
        for robot in robots:
            name, action = robot.name, robot.nav_action
            self._robots[name] = robot
            limits = fleet.world.robots[name].limits
            self.navigators[name] = Navigator(
                world_planner(fleet.world, name), limits, misbehave_after_cancel=misbehave_after_cancel
            )
            twist_type = TWIST_STAMPED if robot.cmd_vel_stamped else TWIST
            self._pubs[(name, "autonomy")] = session.declare_publisher(fleet.key(robot.autonomy_topic, twist_type))
            status_key = self._key(f"{action}/_action/status", nav2_types.STATUS_ARRAY)
            self._pubs[(name, "status")] = _cached_publisher(session, status_key)
            feedback_key = self._key(f"{action}/_action/feedback", nav2_types.FEEDBACK_MESSAGE)
            self._pubs[(name, "feedback")] = session.declare_publisher(feedback_key)
            cancel_key = self._key(f"{action}/_action/cancel_goal", nav2_types.CANCEL_GOAL)
            result_key = self._key(f"{action}/_action/get_result", nav2_types.GET_RESULT)
            self._entities += [
                session.declare_subscriber(fleet.selector(robot.goal_topic), lambda s, r=name: self._on_goal(r, s)),
                session.declare_queryable(
                    cancel_key, lambda q, r=name, k=cancel_key: self._on_cancel(r, k, q), complete=True
                ),
                session.declare_queryable(
                    result_key, lambda q, r=name, k=result_key: self._on_get_result(r, k, q), complete=True
                ),
            ]
            self._publish_status(name)

    # -- wire ---------------------------------------------------------------------------------------

    def _key(self, topic: str, type_name: str) -> str:
        return topic_key("rmw_zenoh", self._fleet.domain, topic, type_name, self.store.hash_rihs01(type_name))

    def _put(self, publisher: Any, message: Any, type_name: str) -> None:
        self._sequence += 1
        attachment = Attachment(self._sequence, time.time_ns(), self._gid).encode()
        publisher.put(bytes(self.store.serialize_cdr(message, type_name)), attachment=attachment)

    def _uuid(self, raw: bytes) -> Any:
        return self._t["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(raw, np.uint8).copy())

    def _goal_info(self, goal: nav.NavGoal) -> Any:
        stamp = self._t["builtin_interfaces/msg/Time"](sec=goal.stamp // 10**9, nanosec=goal.stamp % 10**9)
        return self._t["action_msgs/msg/GoalInfo"](goal_id=self._uuid(goal.uuid), stamp=stamp)

    def _publish_status(self, robot: str) -> None:
        t = self._t
        statuses = [
            t["action_msgs/msg/GoalStatus"](goal_info=self._goal_info(g), status=g.status)
            for g in self.navigators[robot].goals
        ]
        message = t[self._types.STATUS_ARRAY](status_list=statuses)
        self._put(self._pubs[(robot, "status")], message, self._types.STATUS_ARRAY)

    def _publish_feedback(self, robot: str, f: nav.Feedback) -> None:
        t, action = self._t, self._types.ACTION
        qx, qy, qz, qw = yaw_to_quaternion(float(f.yaw))
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=float(f.x), y=float(f.y), z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
        )
        header = self._fleet.header(self._robots[robot].pose.map_frame)
        feedback = t[f"{action}_Feedback"](
            current_pose=t["geometry_msgs/msg/PoseStamped"](header=header, pose=pose),
            navigation_time=_duration(t, f.navigation_time),
            estimated_time_remaining=_duration(t, f.estimated_time_remaining),
            number_of_recoveries=f.number_of_recoveries,
            distance_remaining=float(f.distance_remaining),
        )
        message = t[self._types.FEEDBACK_MESSAGE](goal_id=self._uuid(f.uuid), feedback=feedback)
        self._put(self._pubs[(robot, "feedback")], message, self._types.FEEDBACK_MESSAGE)

    def _reply(self, query: Any, key: str, message: Any, type_name: str, request: Attachment) -> None:
        # rmw_zenoh's service reply: the request's sequence number and client GID, the reply's own time.
        attachment = Attachment(request.sequence, time.time_ns(), request.gid).encode()
        query.reply(key, bytes(self.store.serialize_cdr(message, type_name)), attachment=attachment)

    def _request(self, query: Any, type_name: str) -> tuple[Any, Attachment] | None:
        """A service request's message and attachment, or None after replying an error that names what is wrong."""
        try:
            if query.attachment is None:
                raise ValueError("no rmw_zenoh attachment (sequence number, client GID)")
            attachment = decode_attachment(query.attachment.to_bytes())
            if query.payload is None:
                raise ValueError("no request")
            message = self.store.deserialize_cdr(query.payload.to_bytes(), f"{type_name}_Request")
        except Exception as exc:  # rosbags raises several kinds on bytes that are not the type
            query.reply_err(f"not a {type_name} request: {exc}"[:200].encode())
            query.drop()
            return None
        return message, attachment

    # -- callbacks (Zenoh's threads) ------------------------------------------------------------------

    def _on_goal(self, robot: str, sample: Any) -> None:
        try:
            message = self._fleet.store.deserialize_cdr(sample.payload.to_bytes(), "geometry_msgs/msg/PoseStamped")
        except Exception as exc:
            logger.warning("%s: a goal on %s is not a PoseStamped: %.80s", robot, sample.key_expr, exc)
            return
        p, q = message.pose.position, message.pose.orientation
        yaw = quaternion_to_yaw(q.x, q.y, q.z, q.w)
        with self._lock:
            goal = self.navigators[robot].goal(uuidlib.uuid4().bytes, float(p.x), float(p.y), yaw, time.time())
            self._publish_status(robot)
        logger.info("%s: goal %s to (%.2f, %.2f)", robot, uuidlib.UUID(bytes=goal.uuid), goal.x, goal.y)

    def _on_cancel(self, robot: str, key: str, query: Any) -> None:
        request = self._request(query, self._types.CANCEL_GOAL)
        if request is None:
            return
        message, attachment = request
        info = message.goal_info
        stamp = int(info.stamp.sec) * 10**9 + int(info.stamp.nanosec)
        with self._lock:
            code, goals = self.navigators[robot].cancel(bytes(info.goal_id.uuid), stamp, time.time())
            if goals:
                self._publish_status(robot)
            response_type = f"{self._types.CANCEL_GOAL}_Response"
            response = self._t[response_type](return_code=code, goals_canceling=[self._goal_info(g) for g in goals])
        self._reply(query, key, response, response_type, attachment)
        query.drop()
        logger.info("%s: cancel -> %d (%d goals canceling)", robot, code, len(goals))

    def _on_get_result(self, robot: str, key: str, query: Any) -> None:
        request = self._request(query, self._types.GET_RESULT)
        if request is None:
            return
        message, attachment = request
        uuid = bytes(message.goal_id.uuid)
        with self._lock:
            goal = self.navigators[robot].result(uuid)
            if goal is not None and goal.ended is None:
                self._waiting.setdefault(uuid, []).append((query, key, attachment))  # replied when it ends
                return
        self._answer_result(query, key, attachment, goal)

    def _answer_result(self, query: Any, key: str, attachment: Attachment, goal: nav.NavGoal | None) -> None:
        t, action = self._t, self._types.ACTION
        result = t[f"{action}_Result"](
            error_code=0 if goal is None else goal.error_code, error_msg="" if goal is None else goal.error_msg
        )
        response_type = f"{self._types.GET_RESULT}_Response"
        status = nav.UNKNOWN if goal is None else goal.status
        self._reply(query, key, t[response_type](status=status, result=result), response_type, attachment)
        query.drop()

    # -- the controller (the fleet's loop) --------------------------------------------------------------

    def step(self, now: float) -> None:
        """One controller tick for every robot (every navigator.PERIOD)."""
        answers = []
        with self._lock:
            for robot, navigator in self.navigators.items():
                with self._fleet.lock:
                    state = self._fleet.world.robots[robot].state
                    tick = navigator.step(state, now)
                if tick.command is not None:
                    message, type_name = _twist(self._fleet, self._robots[robot], *tick.command)
                    self._fleet.put(self._pubs[(robot, "autonomy")], message, type_name)
                if tick.feedback is not None:
                    self._publish_feedback(robot, tick.feedback)
                if tick.status_changed:
                    self._publish_status(robot)
                    for goal in navigator.goals:
                        if goal.ended is not None:
                            answers += [(q, k, a, goal) for q, k, a in self._waiting.pop(goal.uuid, [])]
        for query, key, attachment, goal in answers:
            self._answer_result(query, key, attachment, goal)


def _duration(t: Any, seconds: float) -> Any:
    whole = int(seconds)
    return t["builtin_interfaces/msg/Duration"](sec=whole, nanosec=int((seconds - whole) * 1e9))
