"""Fake arms for tools/fake_fleet.py (DDS) and fake_fleet_zenoh.py: each robot of the config with an ``arm:`` gets what
a real one runs.

What the real TurtleBot3 manipulator's launch files bring up, seen from the relay: ros2_control's
joint_state_broadcaster publishing ``sensor_msgs/JointState`` on the robot's ``joint_states`` (the arm's joints, the
gripper's and its mimic), MoveIt Servo taking ``geometry_msgs/TwistStamped`` on ``servo_node/delta_twist_cmds`` in
the arm's base link, and over Zenoh the arm controller's ``trajectory_msgs/JointTrajectory`` and the gripper
controller's GripperCommand goals (the PyPI wheels lack both packages: not over DDS). The arm is the simulator's
(relay/arm/sim_arm.py): the same URDF, kinematics, limits and rules, and its own deadman (Servo's
``incoming_command_timeout``: a twist stream that stops, stops the arm). A twist in another frame is dropped with a
warning, as Servo without that frame's transform would. :class:`Arms` is that, without I/O; :class:`FakeArms` carries
it over DDS, fake_fleet_zenoh.py over Zenoh.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import numpy as np

from relay.arm.fleet_arms import load_fleet_arms
from relay.config import FleetConfig
from relay.fleet.events import JointStateEvent
from relay.sim.arms import JOINT_STATE_RATE, SimArms

Vec3 = tuple[float, float, float]

logger = logging.getLogger("fake_fleet.arm")

#: The arms are integrated this often (Hz): ros2_control's update rate in turtlebot3_manipulation's controller YAML.
STEP_RATE = 100.0


class Arms:
    """The config's arms, as their robots run them: a servo twist in, a step of the kinematics, joint states out. Any
    thread may call it (a lock around the arms). ``timeout``: the arms' deadman (s)."""

    def __init__(self, config: FleetConfig, timeout: float) -> None:
        robots = {robot.name: robot for robot in config.robots}
        self.sim = SimArms(robots, load_fleet_arms(config.robots), timeout)
        self.specs = {name: arm for name in self.sim if (arm := robots[name].arm) is not None}
        self.lock = threading.Lock()

    def __len__(self) -> int:
        return len(self.specs)

    def twist(self, robot: str, frame: str, linear: Vec3, angular: Vec3) -> None:
        """A TwistStamped on the robot's servo topic (``frame``: its header's)."""
        base_link = self.specs[robot].base_link
        if frame != base_link:
            logger.warning("%s's arm: a twist in frame %r dropped (its base link is %s)", robot, frame[:80], base_link)
            return
        with self.lock:
            refused = self.sim.arm(robot, "servo").servo(linear, angular, time.monotonic())
        if refused is not None:
            logger.info("%s's arm: twist refused: %s", robot, refused)

    def trajectory(self, robot: str, names: tuple[str, ...], positions: tuple[float, ...]) -> None:
        """A JointTrajectory on the arm controller's topic: the arm goes to its last point (every joint of the arm
        named, else it is dropped with a warning, as joint_trajectory_controller drops one missing a joint)."""
        arm = self.sim.arm(robot, "trajectory")
        by_name = dict(zip(names, positions, strict=False))
        missing = [name for name in arm.model.names if name not in by_name]
        if missing:
            logger.warning("%s's arm: a trajectory without %s dropped", robot, ", ".join(missing)[:120])
            return
        with self.lock:
            refused = arm.move_to(np.array([by_name[name] for name in arm.model.names]), "trajectory")
        if refused is not None:
            logger.info("%s's arm: trajectory refused: %s", robot, refused)

    def gripper(self, robot: str, position: float) -> bool:
        """A GripperCommand goal: whether the gripper controller accepts it (and then moves there)."""
        with self.lock:
            refused = self.sim.arm(robot, "gripper").gripper(position)
        if refused is not None:
            logger.info("%s's gripper: goal rejected: %s", robot, refused)
        return refused is None

    def step(self) -> None:
        with self.lock:
            self.sim.step(time.monotonic())

    def states(self) -> list[JointStateEvent]:
        with self.lock:
            return self.sim.states(time.time())


class FakeArms:
    """The config's arms on ``node`` (rclpy): their twists in, their joint states out at JOINT_STATE_RATE."""

    def __init__(self, node: Any, config: FleetConfig, timeout: float) -> None:
        from geometry_msgs.msg import TwistStamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        self.arms = Arms(config, timeout)
        self.node = node
        self.JointState = JointState
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.state_pubs: dict[str, Any] = {}
        for name, arm in self.arms.specs.items():
            self.state_pubs[name] = node.create_publisher(JointState, arm.topics.joint_states, reliable)
            node.create_subscription(
                TwistStamped, arm.topics.delta_twist_cmds, lambda m, r=name: self._on_twist(r, m), reliable
            )
            logger.info("%s: an arm on %s, servo on %s", name, arm.topics.joint_states, arm.topics.delta_twist_cmds)
        if self.state_pubs:
            node.create_timer(1.0 / STEP_RATE, self.arms.step)
            node.create_timer(1.0 / JOINT_STATE_RATE, self._publish)

    def __len__(self) -> int:
        return len(self.arms)

    def _on_twist(self, robot: str, message: Any) -> None:
        t = message.twist
        linear, angular = (t.linear.x, t.linear.y, t.linear.z), (t.angular.x, t.angular.y, t.angular.z)
        self.arms.twist(robot, message.header.frame_id, linear, angular)

    def _publish(self) -> None:
        stamp = self.node.get_clock().now().to_msg()
        for event in self.arms.states():
            message = self.JointState()
            message.header.stamp = stamp
            message.name = list(event.names)
            message.position = [float(v) for v in event.positions]
            message.velocity = [float(v) for v in event.velocities]
            self.state_pubs[event.robot].publish(message)
