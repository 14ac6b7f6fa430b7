"""Nav2's interface for the fake fleet's robots over DDS (``tools/fake_fleet.py --nav2``), as a Nav2 robot shows it.

Per robot, with the navigator of ``relay.sim.navigator`` (planned and followed on the sim's grid):

- ``goal_pose`` (geometry_msgs/PoseStamped) in, as bt_navigator takes it: a new NavigateToPose goal;
- ``<action>/_action/status`` (action_msgs/GoalStatusArray; reliable, transient local, depth 1: rcl_action's QoS),
  published on every change;
- ``<action>/_action/cancel_goal`` (action_msgs/srv/CancelGoal), answered as rcl_action does;
- the controller's velocity on ``navigation.autonomy`` (``<ns>/cmd_vel_nav``; Twist, or TwistStamped with
  ``cmd_vel.stamped``) at 20 Hz while a goal executes. The base moves only from ``cmd_vel``: the watchdog's.
- with ``nav2_msgs`` importable (a sourced ROS; the PyPI wheels have none): ``<action>/_action/feedback``
  (NavigateToPose's FeedbackMessage) and ``<action>/_action/get_result``, answered at once (Nav2 waits for a
  running goal's end; the relay asks only about ended ones).
"""

from __future__ import annotations

import argparse
import logging
import time
import uuid as uuidlib
from collections.abc import Callable, Sequence
from typing import Any

from relay.config import FleetConfig, Robot
from relay.errors import ConfigError
from relay.fleet.geometry import quaternion_to_yaw, yaw_to_quaternion
from relay.sim import navigator as nav
from relay.sim.navigator import Navigator, world_planner
from relay.sim.world import SimWorld

logger = logging.getLogger("fake_fleet.nav2")


def add_nav2_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--nav2", action="store_true", help="navigate as Nav2 does: action status, cancel, cmd_vel_nav")
    parser.add_argument(
        "--misbehave-after-cancel", action="store_true",
        help="with --nav2: the controller keeps publishing after a cancel (the watchdog's gate must hold)",
    )  # fmt: skip


def nav2_ready(config: FleetConfig) -> None:
    """ConfigError naming the first robot whose navigation could not move it: with --nav2 the base moves only from
    cmd_vel, which only the watchdog publishes."""
    for index, robot in enumerate(config.robots):
        if robot.watchdog_topic is None:
            raise ConfigError(
                config.source, None, f"robots[{index}].cmd_vel.watchdog",
                f"{robot.name}: --nav2 needs it: the watchdog forwards {robot.autonomy_topic} to {robot.cmd_vel_topic}",
            )  # fmt: skip


def _nav2_msgs() -> Any | None:
    try:
        from nav2_msgs.action import NavigateToPose
    except ImportError:
        return None
    return NavigateToPose


class Nav2Servers:
    """The navigators of some robots of ``world`` on one rclpy node, and their ROS interface."""

    def __init__(
        self, node: Any, world: SimWorld, robots: Sequence[Robot], *, misbehave_after_cancel: bool = False,
        clock: Callable[[], float] = time.time,
    ) -> None:  # fmt: skip
        from action_msgs.msg import GoalInfo, GoalStatus, GoalStatusArray
        from action_msgs.srv import CancelGoal
        from builtin_interfaces.msg import Time
        from geometry_msgs.msg import PoseStamped, Twist, TwistStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from unique_identifier_msgs.msg import UUID

        self._node, self._world, self._clock = node, world, clock
        self._msg = {"GoalInfo": GoalInfo, "GoalStatus": GoalStatus, "GoalStatusArray": GoalStatusArray}
        self._msg.update({"Time": Time, "UUID": UUID, "Twist": Twist, "TwistStamped": TwistStamped})
        self._action = _nav2_msgs()
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        status_qos = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        self.navigators: dict[str, Navigator] = {}
        self._robots: dict[str, Robot] = {}
        self._pubs: dict[tuple[str, str], Any] = {}
        for robot in robots:
            name, action = robot.name, robot.nav_action
            self._robots[name] = robot
            self.navigators[name] = Navigator(
                world_planner(world, name), world.robots[name].limits, misbehave_after_cancel=misbehave_after_cancel
            )
            twist = TwistStamped if robot.cmd_vel_stamped else Twist
            self._pubs[(name, "autonomy")] = node.create_publisher(twist, robot.autonomy_topic, reliable)
            self._pubs[(name, "status")] = node.create_publisher(
                GoalStatusArray, f"{action}/_action/status", status_qos
            )
            node.create_service(
                CancelGoal, f"{action}/_action/cancel_goal", lambda q, a, r=name: self._on_cancel(r, q, a)
            )
            node.create_subscription(PoseStamped, robot.goal_topic, lambda m, r=name: self._on_goal(r, m), reliable)
            if self._action is not None:
                impl = self._action.Impl
                self._pubs[(name, "feedback")] = node.create_publisher(
                    impl.FeedbackMessage, f"{action}/_action/feedback", reliable
                )
                node.create_service(
                    impl.GetResultService, f"{action}/_action/get_result",
                    lambda q, a, r=name: self._on_get_result(r, q, a),
                )  # fmt: skip
            self._publish_status(name)
        node.create_timer(nav.PERIOD, self._step)
        logger.info(
            "Nav2 navigators for %s%s",
            ", ".join(self.navigators),
            "" if self._action else " (no nav2_msgs: no feedback)",
        )

    # -- messages ---------------------------------------------------------------------------------

    def _goal_info(self, goal: nav.NavGoal) -> Any:
        m = self._msg
        stamp = m["Time"](sec=goal.stamp // 1_000_000_000, nanosec=goal.stamp % 1_000_000_000)
        return m["GoalInfo"](goal_id=m["UUID"](uuid=list(goal.uuid)), stamp=stamp)

    def _publish_status(self, robot: str) -> None:
        m = self._msg
        statuses = [
            m["GoalStatus"](goal_info=self._goal_info(g), status=g.status) for g in self.navigators[robot].goals
        ]
        self._pubs[(robot, "status")].publish(m["GoalStatusArray"](status_list=statuses))

    def _publish_command(self, robot: str, linear: float, angular: float) -> None:
        spec = self._robots[robot]
        if spec.cmd_vel_stamped:
            message = self._msg["TwistStamped"]()
            message.header.stamp = self._node.get_clock().now().to_msg()
            message.header.frame_id = spec.pose.base_frame
            twist = message.twist
        else:
            message = twist = self._msg["Twist"]()
        twist.linear.x, twist.angular.z = float(linear), float(angular)
        self._pubs[(robot, "autonomy")].publish(message)

    def _publish_feedback(self, robot: str, feedback: nav.Feedback) -> None:
        assert self._action is not None
        message = self._action.Impl.FeedbackMessage()
        message.goal_id.uuid = list(feedback.uuid)
        f = message.feedback
        f.current_pose.header.stamp = self._node.get_clock().now().to_msg()
        f.current_pose.header.frame_id = self._robots[robot].pose.map_frame
        f.current_pose.pose.position.x, f.current_pose.pose.position.y = float(feedback.x), float(feedback.y)
        o = f.current_pose.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(float(feedback.yaw))
        f.navigation_time = _duration(feedback.navigation_time)
        f.estimated_time_remaining = _duration(feedback.estimated_time_remaining)
        f.number_of_recoveries = feedback.number_of_recoveries
        f.distance_remaining = float(feedback.distance_remaining)
        self._pubs[(robot, "feedback")].publish(message)

    # -- callbacks (the node's one executor thread) -----------------------------------------------

    def _on_goal(self, robot: str, message: Any) -> None:
        p, q = message.pose.position, message.pose.orientation
        yaw = quaternion_to_yaw(q.x, q.y, q.z, q.w)
        goal = self.navigators[robot].goal(uuidlib.uuid4().bytes, float(p.x), float(p.y), yaw, self._clock())
        logger.info("%s: goal %s to (%.2f, %.2f)", robot, uuidlib.UUID(bytes=goal.uuid), goal.x, goal.y)
        self._publish_status(robot)

    def _on_cancel(self, robot: str, request: Any, response: Any) -> Any:
        info = request.goal_info
        stamp = info.stamp.sec * 1_000_000_000 + info.stamp.nanosec
        code, goals = self.navigators[robot].cancel(bytes(info.goal_id.uuid), stamp, self._clock())
        response.return_code = code
        response.goals_canceling = [self._goal_info(g) for g in goals]
        logger.info("%s: cancel -> %d (%d goals canceling)", robot, code, len(goals))
        if goals:
            self._publish_status(robot)
        return response

    def _on_get_result(self, robot: str, request: Any, response: Any) -> Any:
        # Answered at once: rcl_action answers a running goal's request when it ends, which needs a coroutine, and the
        # executor rclpy.spin uses here never awaited one (the relay got no answer). The relay asks only about goals
        # that ended; a running one is answered with its status now.
        assert self._action is not None
        goal = self.navigators[robot].result(bytes(request.goal_id.uuid))
        response.status = nav.UNKNOWN if goal is None else goal.status
        if goal is not None:
            response.result.error_code = goal.error_code
            response.result.error_msg = goal.error_msg
        return response

    def _step(self) -> None:
        now = self._clock()
        for robot, navigator in self.navigators.items():
            tick = navigator.step(self._world.robots[robot].state, now)
            if tick.command is not None:
                self._publish_command(robot, *tick.command)
            if tick.feedback is not None and self._action is not None:
                self._publish_feedback(robot, tick.feedback)
            if tick.status_changed:
                self._publish_status(robot)


def _duration(seconds: float) -> Any:
    from builtin_interfaces.msg import Duration

    whole = int(seconds)
    return Duration(sec=whole, nanosec=int((seconds - whole) * 1e9))
