"""The watchdog as a ROS 2 node: ``xr-relay watchdog`` (or ``python tools/watchdog.py``), run on or next to robots.

    xr-relay watchdog --config robots.yaml [--robot robot1 ...] [--timeout 0.5]

For every robot whose ``cmd_vel.watchdog`` is set in robots.yaml (or those named), it is the only publisher of the
robot's ``cmd_vel`` (Twist, or TwistStamped when ``cmd_vel.stamped``): it subscribes to the relay's teleop
(TwistStamped on the watchdog topic), the robot's own navigation output (``navigation.autonomy``, default
``<ns>/cmd_vel_nav``, the same type as cmd_vel), the relay's heartbeat (``ros.heartbeat_topic``) and the relay's
gate (``<ns>/xr_relay/gate``, std_msgs/String ``drive``/``hold``/``estop``, transient local), forwards what the
rules allow (``relay.watchdog.rules``: teleop over autonomy, autonomy only on ``drive``, nothing but zeros at 20 Hz
while an estop is latched), and publishes its gate on ``<ns>/xr_relay/gate_state`` (transient local) at start and on
every change. ``tools/fake_fleet.py`` attaches the same watchdogs to its own node. Set-up: docs/reliability.md.
"""

from __future__ import annotations

import argparse
import logging
import signal
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..config import FleetConfig, Robot, load_config
from ..errors import ConfigError
from .rules import Verdict, WatchdogRules

logger = logging.getLogger("xr_relay.watchdog")

#: How often the rules are checked (s): a stop comes at most this long after the timeout.
TICK = 0.02


class Watchdogs:
    """The watchdogs of some robots on one rclpy node: each the only publisher of its robot's ``cmd_vel``."""

    def __init__(
        self, node: Any, config: FleetConfig, robots: Sequence[Robot], timeout: float,
        clock: Callable[[], float] = time.time,
    ) -> None:  # fmt: skip
        from geometry_msgs.msg import Twist, TwistStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Header, String

        self._clock = clock
        self._twist, self._twist_stamped, self._string = Twist, TwistStamped, String
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        # The gate is the relay's last word and gate_state the watchdog's: a late subscriber (a watchdog started
        # after an estop, a relay started after one) gets it from the publisher's history.
        latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        self.rules: dict[str, WatchdogRules] = {}
        self._robots: dict[str, Robot] = {}
        self._publishers: dict[str, Any] = {}
        self._gate_states: dict[str, Any] = {}
        self._dropping: dict[tuple[str, str], str] = {}  # (robot, source) -> the reason last logged
        for robot in robots:
            assert robot.watchdog_topic is not None
            name = robot.name
            self.rules[name] = WatchdogRules(timeout, robot.on_relay_lost)
            self._robots[name] = robot
            cls = TwistStamped if robot.cmd_vel_stamped else Twist
            self._publishers[name] = node.create_publisher(cls, robot.cmd_vel_topic, reliable)
            self._gate_states[name] = node.create_publisher(String, robot.gate_state_topic, latched)
            node.create_subscription(
                TwistStamped, robot.watchdog_topic, lambda m, r=name: self._on_command(r, m), reliable
            )
            node.create_subscription(cls, robot.autonomy_topic, lambda m, r=name: self._on_autonomy(r, m), reliable)
            node.create_subscription(String, robot.gate_topic, lambda m, r=name: self._on_gate(r, m), latched)
            self._publish_gate_state(name)
        node.create_subscription(Header, config.ros.heartbeat_topic, self._on_heartbeat, reliable)
        self._node = node
        self._timer = node.create_timer(TICK, self._tick)
        logger.info(
            "watching %s (timeout %g s, heartbeat %s)", ", ".join(self.rules), timeout, config.ros.heartbeat_topic
        )

    def _on_heartbeat(self, _message: Any) -> None:
        now = self._clock()
        for rules in self.rules.values():
            rules.heartbeat(now)

    def _on_gate(self, robot: str, message: Any) -> None:
        rules = self.rules[robot]
        before = rules.gate
        try:
            reason = rules.set_gate(message.data, self._clock())
        except ValueError as exc:
            logger.warning("%s: gate word ignored: %s", robot, exc)
            return
        if reason is not None:
            logger.warning("%s: stopped: %s", robot, reason)
            self._publish(robot, None)
        if rules.gate != before:
            logger.info("%s: gate %s -> %s", robot, before, rules.gate)
            self._publish_gate_state(robot)

    def _on_command(self, robot: str, message: Any) -> None:
        stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        twist = message.twist
        verdict = self.rules[robot].command(twist.linear.x, twist.angular.z, stamp, self._clock())
        self._forward(robot, "teleop", twist, verdict)

    def _on_autonomy(self, robot: str, message: Any) -> None:
        twist = message.twist if self._robots[robot].cmd_vel_stamped else message
        verdict = self.rules[robot].autonomy(twist.linear.x, twist.angular.z, self._clock())
        self._forward(robot, "autonomy", twist, verdict)

    def _forward(self, robot: str, source: str, twist: Any, verdict: Verdict) -> None:
        if verdict.forward:
            self._dropping.pop((robot, source), None)
            self._publish(robot, twist)
        elif self._dropping.get((robot, source)) != verdict.reason:
            # Once per reason, not per message: a controller held by the gate publishes 20 a second.
            self._dropping[(robot, source)] = verdict.reason
            logger.warning("%s: %s not forwarded: %s", robot, source, verdict.reason)

    def _tick(self) -> None:
        now = self._clock()
        for robot, rules in self.rules.items():
            reason = rules.tick(now)
            if reason is not None:
                if rules.gate != "estop":  # an estop's zeros come at 20 Hz: its start is logged, not each one
                    logger.warning("%s: stopped: %s", robot, reason)
                self._publish(robot, None)

    def _publish(self, robot: str, twist: Any | None) -> None:
        """``twist`` (its six components) on the robot's cmd_vel, or a zero for None."""
        spec = self._robots[robot]
        if spec.cmd_vel_stamped:
            message = self._twist_stamped()
            message.header.stamp = self._node.get_clock().now().to_msg()
            message.header.frame_id = spec.pose.base_frame
            out = message.twist
        else:
            message = out = self._twist()
        if twist is not None:
            for part in ("linear", "angular"):
                v, w = getattr(twist, part), getattr(out, part)
                w.x, w.y, w.z = float(v.x), float(v.y), float(v.z)
        self._publishers[robot].publish(message)

    def _publish_gate_state(self, robot: str) -> None:
        self._gate_states[robot].publish(self._string(data=self.rules[robot].gate))

    def stop_all(self) -> None:
        """Zero every robot that was moving or is latched (on the watchdog's own shutdown)."""
        for robot, rules in self.rules.items():
            if rules.moving or rules.gate == "estop":
                rules.moving = False
                self._publish(robot, None)


def watched(config: FleetConfig, names: Sequence[str] = ()) -> list[Robot]:
    """The robots to watch: those named (each must have a watchdog topic), else all that have one."""
    if not names:
        return [robot for robot in config.robots if robot.watchdog_topic is not None]
    robots = []
    for name in names:
        robot = config.robot(name)
        if robot is None:
            fleet = ", ".join(config.names)
            raise ConfigError(config.source, None, "--robot", f"unknown robot {name!r}; the fleet is {fleet}")
        if robot.watchdog_topic is None:
            raise ConfigError(
                config.source, None, f"{name}.cmd_vel.watchdog", "not set: the relay publishes on cmd_vel itself"
            )
        robots.append(robot)
    return robots


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="xr-relay watchdog", description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, default=Path("robots.yaml"), help="the relay's robots.yaml")
    parser.add_argument("--robot", action="append", default=[], help="watch only this robot (repeatable)")
    parser.add_argument("--timeout", type=float, help="seconds (default: safety.deadman_timeout of the config)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        config = load_config(args.config)
        robots = watched(config, args.robot)
    except (ConfigError, OSError) as exc:
        print(f"xr-relay watchdog: {exc}")  # noqa: T201
        return 2
    if not robots:
        print(f"xr-relay watchdog: no robot in {args.config} sets cmd_vel.watchdog; nothing to watch")  # noqa: T201
        return 2
    timeout = args.timeout if args.timeout is not None else config.safety.deadman_timeout
    if not timeout > 0:
        print("xr-relay watchdog: --timeout must be positive")  # noqa: T201
        return 2
    import rclpy
    from rclpy.executors import ExternalShutdownException

    rclpy.init()
    node = rclpy.create_node("xr_relay_watchdog")
    watchdogs = Watchdogs(node, config, robots, timeout)
    stopping = False

    def on_signal(_signum: int, _frame: object) -> None:
        nonlocal stopping
        stopping = True

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    print(f"xr-relay watchdog: watching {', '.join(r.name for r in robots)}", flush=True)  # noqa: T201
    try:
        while not stopping and rclpy.ok():
            rclpy.spin_once(node, timeout_sec=TICK)
    except ExternalShutdownException:
        pass
    finally:
        watchdogs.stop_all()
        rclpy.spin_once(node, timeout_sec=0.05)  # let the zeros go out
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
