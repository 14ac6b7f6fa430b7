"""A stand-in for the relay on a robot's DDS graph, for the gate's tests (tests/test_gate.py): what the relay sends a
robot (the gate's word, the heartbeat, teleop, goals, cancels) and what the test watches (what reaches the base on
cmd_vel, the controller's cmd_vel_nav, the pose, the watchdog's gate_state, the action's status).

rclpy in the test's process on a context of its own, spun in a thread; every message is noted with the time it
arrived (time.monotonic). The relay's publishers live on a node of their own, so that the relay can die (its node
destroyed: its gate publisher, heartbeat and teleop gone) while the test keeps watching.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

from relay.config import FleetConfig

#: (arrival time, linear.x, angular.z)
Sample = tuple[float, float, float]


class DdsRelay:
    def __init__(self, config: FleetConfig, name: str = "relay_stand_in") -> None:
        import rclpy
        from action_msgs.msg import GoalStatusArray
        from action_msgs.srv import CancelGoal
        from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
        from nav_msgs.msg import Odometry
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Header, String

        self._rclpy, self._string, self._header = rclpy, String, Header
        self._twist_stamped, self._pose = TwistStamped, PoseStamped
        self.config = config
        self.context = Context()
        rclpy.init(context=self.context)
        self.relay = rclpy.create_node(name, context=self.context)
        self.watcher = rclpy.create_node(f"{name}_watcher", context=self.context)
        self._reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self._latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        self.lock = threading.Lock()
        self.cmd_vel: dict[str, list[Sample]] = {}
        self.autonomy: dict[str, list[Sample]] = {}
        self.poses: dict[str, list[tuple[float, float, float]]] = {}  # (t, x, y)
        self.gate_states: dict[str, list[str]] = {}
        self.statuses: dict[str, list[tuple[bytes, int]]] = {}
        self.status_heard: set[str] = set()  # the latest status list: (goal UUID, status)
        self.heartbeat_on = True
        self._pubs: dict[str, Any] = {}
        self._cancel: dict[str, Any] = {}
        for robot in config.robots:
            n = robot.name
            for store in (self.cmd_vel, self.autonomy, self.poses, self.gate_states, self.statuses):
                store[n] = []
            self._pubs[f"{n}/gate"] = self.relay.create_publisher(String, robot.gate_topic, self._latched)
            assert robot.watchdog_topic is not None
            self._pubs[f"{n}/teleop"] = self.relay.create_publisher(TwistStamped, robot.watchdog_topic, self._reliable)
            self._pubs[f"{n}/goal"] = self.relay.create_publisher(PoseStamped, robot.goal_topic, self._reliable)
            twist = TwistStamped if robot.cmd_vel_stamped else Twist
            self._watch(twist, robot.cmd_vel_topic, self.cmd_vel[n], robot.cmd_vel_stamped)
            self._watch(twist, robot.autonomy_topic, self.autonomy[n], robot.cmd_vel_stamped)
            self.watcher.create_subscription(
                Odometry, robot.pose.topic, lambda m, s=self.poses[n]: self._note(s, m.pose.pose.position), 10
            )
            self.watcher.create_subscription(
                String, robot.gate_state_topic, lambda m, s=self.gate_states[n]: self._note_word(s, m), self._latched
            )
            self.watcher.create_subscription(
                GoalStatusArray, f"{robot.nav_action}/_action/status",
                lambda m, r=n: self._note_status(r, m), self._latched,
            )  # fmt: skip
            self._cancel[n] = self.watcher.create_client(CancelGoal, f"{robot.nav_action}/_action/cancel_goal")
        self._heartbeat = self.relay.create_publisher(Header, config.ros.heartbeat_topic, self._reliable)
        self.relay.create_timer(0.1, self._beat)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.relay)
        self.executor.add_node(self.watcher)
        self._relay_alive = True
        self._running = True
        self._thread = threading.Thread(target=self._spin, name="dds-relay-stand-in", daemon=True)
        self._thread.start()

    @contextlib.contextmanager
    def _paused(self) -> Iterator[None]:
        """The executor stopped meanwhile: entities are not created or destroyed under a spinning executor."""
        self._running = False
        self._thread.join(5)
        try:
            yield
        finally:
            self._running = True
            self._thread = threading.Thread(target=self._spin, name="dds-relay-stand-in", daemon=True)
            self._thread.start()

    # -- what the relay sends -----------------------------------------------------------------------

    def gate(self, robot: str, word: str) -> None:
        self._pubs[f"{robot}/gate"].publish(self._string(data=word))

    def teleop(self, robot: str, linear: float, angular: float = 0.0) -> None:
        message = self._twist_stamped()
        now = time.time()
        message.header.stamp.sec, message.header.stamp.nanosec = int(now), int((now - int(now)) * 1e9)
        message.twist.linear.x, message.twist.angular.z = float(linear), float(angular)
        self._pubs[f"{robot}/teleop"].publish(message)

    def goal(self, robot: str, x: float, y: float, timeout: float = 30.0) -> bytes:
        """Publishes a goal once the navigator listens; the UUID it gets, from the action's status."""
        publisher = self._pubs[f"{robot}/goal"]
        wait_until(lambda: publisher.get_subscription_count() > 0, timeout, f"{robot}'s navigator on goal_pose")
        # The goals known before this one: the status list must have been heard (a late joiner's history comes
        # asynchronously), or an old goal would pass for the new one.
        wait_until(lambda: robot in self.status_heard, timeout, f"{robot}'s action status")
        with self.lock:
            known = {uuid for uuid, _ in self.statuses[robot]}
        message = self._pose()
        message.header.frame_id = "map"
        message.pose.position.x, message.pose.position.y = float(x), float(y)
        message.pose.orientation.w = 1.0
        publisher.publish(message)
        uuid: bytes = wait_until(lambda: self.new_goal(robot, known), 10, f"{robot}'s new goal in the action's status")
        return uuid

    def new_goal(self, robot: str, known: set[bytes]) -> bytes | None:
        with self.lock:
            return next((uuid for uuid, _ in self.statuses[robot] if uuid not in known), None)

    def cancel(self, robot: str, uuid: bytes = bytes(16), timeout: float = 10.0) -> Any:
        """Calls the action's cancel_goal service; its response."""
        from action_msgs.srv import CancelGoal

        client = self._cancel[robot]
        wait_until(client.service_is_ready, timeout, f"{robot}'s cancel_goal service")
        request = CancelGoal.Request()
        request.goal_info.goal_id.uuid = list(uuid)
        future = client.call_async(request)
        return wait_until(lambda: future.result() if future.done() else None, timeout, "the cancel response")

    def die(self) -> None:
        """The relay is gone: its node (gate publisher, heartbeat, teleop, goals) destroyed; the watcher stays."""
        with self._paused():
            self.executor.remove_node(self.relay)
            self.relay.destroy_node()
            self._relay_alive = False

    # -- what the test watches ----------------------------------------------------------------------

    def status(self, robot: str, uuid: bytes) -> int | None:
        with self.lock:
            return next((s for u, s in self.statuses[robot] if u == uuid), None)

    def since(self, samples: list[Sample], start: float) -> list[Sample]:
        with self.lock:
            return [s for s in samples if s[0] >= start]

    def pose(self, robot: str) -> tuple[float, float]:
        """The latest pose (waiting for the first)."""
        wait_until(lambda: self.poses[robot], 30, f"{robot}'s pose")
        with self.lock:
            _, x, y = self.poses[robot][-1]
        return x, y

    def pose_at(self, robot: str, at: float) -> tuple[float, float]:
        """The first pose that arrived at or after ``at``."""
        with self.lock:
            _, x, y = next(p for p in self.poses[robot] if p[0] >= at)
        return x, y

    def late_gate_state(self, robot: str, timeout: float = 10.0) -> str:
        """What a subscriber that starts now (a new relay) hears on gate_state, from the publisher's history."""
        spec = self.config.robot(robot)
        assert spec is not None
        heard: list[str] = []
        with self._paused():
            subscription = self.watcher.create_subscription(
                self._string, spec.gate_state_topic, lambda m: self._note_word(heard, m), self._latched
            )
        try:
            word: str = wait_until(lambda: heard[-1] if heard else None, timeout, f"{robot}'s gate_state")
            return word
        finally:
            with self._paused():
                self.watcher.destroy_subscription(subscription)

    def close(self) -> None:
        self._running = False
        self._thread.join(5)
        self.executor.shutdown()
        for node in (self.relay, self.watcher):
            if node is not self.relay or self._relay_alive:
                node.destroy_node()
        self._rclpy.try_shutdown(context=self.context)

    # -- internals ------------------------------------------------------------------------------------

    def _watch(self, cls: Any, topic: str, samples: list[Sample], stamped: bool) -> None:
        def note(message: Any) -> None:
            twist = message.twist if stamped else message
            with self.lock:
                samples.append((time.monotonic(), twist.linear.x, twist.angular.z))

        self.watcher.create_subscription(cls, topic, note, self._reliable)

    def _note(self, poses: list[tuple[float, float, float]], position: Any) -> None:
        with self.lock:
            poses.append((time.monotonic(), position.x, position.y))

    def _note_word(self, words: list[str], message: Any) -> None:
        with self.lock:
            words.append(message.data)

    def _note_status(self, robot: str, message: Any) -> None:
        with self.lock:
            self.status_heard.add(robot)
            self.statuses[robot] = [(bytes(s.goal_info.goal_id.uuid), s.status) for s in message.status_list]

    def _beat(self) -> None:
        if self.heartbeat_on:
            message = self._header()
            message.stamp = self.relay.get_clock().now().to_msg()
            self._heartbeat.publish(message)

    def _spin(self) -> None:
        while self._running and self.context.ok():
            self.executor.spin_once(timeout_sec=0.05)


def wait_until(check: Callable[[], Any], timeout: float, what: str) -> Any:
    """``check()``'s first truthy value, polled every 20 ms; AssertionError naming ``what`` after ``timeout``."""
    deadline = time.monotonic() + timeout
    while True:
        value = check()
        if value:
            return value
        assert time.monotonic() < deadline, f"no {what} within {timeout:g} s"
        time.sleep(0.02)
