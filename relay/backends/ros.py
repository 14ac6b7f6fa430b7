"""The ``ros`` backend: a live ROS 2 graph through rclpy. The only module that imports rclpy.

rclpy is imported lazily when the backend is created, so the relay runs without ROS for the other
backends; without it, this backend refuses to start with one line saying how to get it.

**The thread boundary.** One executor thread spins the node (relay/backends/ros_spinner.py). Callbacks run there
and cross to the asyncio loop as relay/backends/live.py says, as the zenoh backend's do.

Executor and decoding: every high-rate topic raw, poses decoded by hand, TF, scans and images by rosbags
(relay/backends/ingest.py says why, with the figures), the EventsExecutor spun from its thread until a future is
done (relay/backends/ros_spinner.py; bench/bench_ros_ingest.py measures it against bare subscribers every run).
Low-rate topics (sensors, paths, the map, robot descriptions) keep rclpy's messages.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import logging
import os
from collections.abc import Callable
from typing import Any

from ..arm.named import JointGoal
from ..config import Camera, FleetConfig, Robot
from ..errors import BackendUnavailable
from ..fleet.events import EventSink, PathEvent, RobotModelEvent, SensorEvent
from ..fleet.geometry import yaw_to_quaternion
from ..ros.ros_env import load_rclpy
from ..ros.rosmsg import POSE_MESSAGES, SENSOR_TYPES, message_stamp
from . import dds_profile
from .base import Vec3
from .cloud_intake import CAMERA_INFO, TF_MESSAGE, message_type, static_topic
from .ingest import RawDecoder
from .live import LiveBackend
from .ros_arms import RosArms, stamp_header
from .ros_nav2 import RosNav2, needed_messages
from .ros_spinner import Spinner

logger = logging.getLogger(__name__)


#: History depth of image subscriptions (see ``_qos``).
IMAGE_DEPTH = 10


def _import(module: str, name: str) -> Any:
    return getattr(importlib.import_module(module), name)


def check_messages(config: FleetConfig) -> dict[str, Any]:
    """Import every message class the config needs, now: a missing package is a start-up error."""
    needed: dict[str, tuple[str, str, str]] = {}  # key -> (module, class, who needs it)
    for robot in config.robots:
        module, cls = POSE_MESSAGES[robot.pose.source]
        needed[f"{module}.{cls}"] = (module, cls, f"{robot.name}: pose source '{robot.pose.source}'")
        for sensor in robot.sensors:
            module, cls = SENSOR_TYPES[sensor.type].module, SENSOR_TYPES[sensor.type].cls
            needed.setdefault(f"{module}.{cls}", (module, cls, f"{robot.name}: sensor '{sensor.name}'"))
    if any(robot.model_source is not None for robot in config.robots):
        needed.setdefault("std_msgs.msg.String", ("std_msgs.msg", "String", "robot models from robot_description"))
    for module, cls, who in needed_messages(config.robots):
        needed.setdefault(f"{module}.{cls}", (module, cls, who))
    for robot in config.robots if config.cloud is not None else ():
        for source in robot.clouds:
            for type_name in (message_type(source), CAMERA_INFO if source.camera_info else None):
                if type_name is not None:
                    needed.setdefault(_key(type_name), (*_class(type_name), f"{robot.name}: cloud '{source.name}'"))
        if static_topic(robot) is not None:
            who = f"{robot.name}: a cloud without a mount (placed through {static_topic(robot)})"
            needed.setdefault(_key(TF_MESSAGE), (*_class(TF_MESSAGE), who))
    for module, cls in (
        ("geometry_msgs.msg", "Twist"),
        ("geometry_msgs.msg", "TwistStamped"),
        ("geometry_msgs.msg", "PoseStamped"),
        ("sensor_msgs.msg", "JointState"),
        ("sensor_msgs.msg", "Image"),
        ("sensor_msgs.msg", "CompressedImage"),
        ("sensor_msgs.msg", "LaserScan"),
        ("nav_msgs.msg", "OccupancyGrid"),
        ("nav_msgs.msg", "Path"),
        ("std_msgs.msg", "Header"),
    ):
        needed.setdefault(f"{module}.{cls}", (module, cls, "the relay"))
    classes: dict[str, Any] = {}
    problems: list[str] = []
    for key, (module, cls, who) in needed.items():
        try:
            classes[key] = _import(module, cls)
        except (ImportError, AttributeError):
            package = module.split(".")[0]
            hint = ""
            if package == "tf2_msgs":
                hint = (
                    " (the PyPI ROS wheels do not include it): use pose source odom, amcl_pose or pose and give "
                    "clouds a mount in robots.yaml, or source a ROS 2 installation that has tf2_msgs"
                )
            problems.append(f"{who} needs the message package {package}, which is not installed{hint}")
    if problems:
        raise BackendUnavailable("; ".join(problems))
    return classes


def _class(type_name: str) -> tuple[str, str]:
    """The rclpy module and class of a message type: ``sensor_msgs/msg/Image`` -> (``sensor_msgs.msg``, ``Image``)."""
    package, _, name = type_name.rpartition("/")
    return package.replace("/", "."), name


def _key(type_name: str) -> str:
    return ".".join(_class(type_name))


class RosBackend(LiveBackend):
    """The robots of a ROS 2 graph: one rclpy node, its executor thread, and its publishers of commands."""

    name = "ros"

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        # Goals, their outcomes and the watchdogs' gates (relay/backends/navigation.py, shared with zenoh).
        self._nav2 = RosNav2(config, self._hop, self._to_navigation, self._decode_raw)
        super().__init__(config, sink, self._nav2, warn=logger.warning)
        # Importing rclpy and the message packages takes a few hundred milliseconds: ``start`` does it in
        # a worker thread, and a missing package still stops the relay before it serves anything.
        self._rclpy: Any = None
        self._messages: dict[str, Any] = {}
        self._context: Any = None
        self._node: Any = None
        self._spinner: Spinner | None = None
        self._cmd_pubs: dict[str, Any] = {}
        self._goal_pubs: dict[str, Any] = {}
        self._arms = RosArms(self._msg, self._post)  # MoveIt Servo's topics of each robot with an arm
        self._heartbeat_pub: Any = None
        #: The Fast DDS profile in effect (dds_profile.apply), for /healthz.
        self.dds_profile = ""

    def _msg(self, module: str, cls: str) -> Any:
        return self._messages[f"{module}.{cls}"]

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        await super().start()
        logger.info(
            "ros backend: node xr_relay in ROS_DOMAIN_ID %s, %d robots, %s executor",
            os.environ.get("ROS_DOMAIN_ID", "0"),
            len(self.config.robots),
            self._spinner.kind if self._spinner is not None else "no",
        )

    def _connect(self) -> None:
        """Worker thread: import ROS, check every message package, create the node and start spinning."""
        self.dds_profile = dds_profile.apply(self.config.ros.dds_profile)  # before the first participant
        self._rclpy = rclpy = load_rclpy()
        self._messages = check_messages(self.config)
        if self._decode is None:
            self._decode = RawDecoder()
        context_mod = importlib.import_module("rclpy.context")
        executors = importlib.import_module("rclpy.executors")
        self._context = context_mod.Context()
        rclpy.init(context=self._context)
        self._node = rclpy.create_node("xr_relay", context=self._context)
        for robot in self.config.robots:
            self._create_robot(robot)
        self._nav2.create(self._node, self._msg, importlib.import_module("rclpy.qos"))
        self._node.create_subscription(
            self._msg("nav_msgs.msg", "OccupancyGrid"), self.config.ros.map_topic, self._on_map, self._qos("map")
        )
        self._heartbeat_pub = None
        if any(robot.watchdog_topic is not None for robot in self.config.robots):
            self._heartbeat_pub = self._node.create_publisher(
                self._msg("std_msgs.msg", "Header"), self.config.ros.heartbeat_topic, self._qos("commands")
            )
        self._spinner = Spinner(executors, self._context, self.config.ros.executor, self._executor_failed)
        self._spinner.start(self._node)

    def _connected(self) -> bool:
        return self._node is not None

    def health(self) -> dict[str, object]:
        return {"dds_profile": self.dds_profile, **self.cloud_health()}

    def _executor_failed(self, why: str) -> None:
        if self._node is not None:
            self.failure = why

    async def recover(self) -> None:
        """Re-create the node, its subscriptions and publishers, and the executor thread."""
        old_spinner, old_node, old_context = self._spinner, self._node, self._context

        def rebuild() -> None:
            with contextlib.suppress(Exception):  # the old node is already half gone: best effort
                _shut_down(self._rclpy, old_spinner, old_node, old_context)
            self._cameras.forget_subscriptions()
            self._connect()

        await asyncio.to_thread(rebuild)
        self._cameras.resubscribe()
        self.failure = None
        logger.warning("ros backend recovered: node and subscriptions re-created")

    def _send_heartbeat(self, when: float) -> None:
        if self._heartbeat_pub is None or self._node is None:
            return
        header = self._msg("std_msgs.msg", "Header")()
        header.frame_id = "xr_relay"
        stamp_header(header, when)
        self._heartbeat_pub.publish(header)

    async def _disconnect(self) -> None:
        spinner, node, context = self._spinner, self._node, self._context
        self._node = None
        await asyncio.to_thread(_shut_down, self._rclpy, spinner, node, context)

    def _qos(self, kind: str) -> Any:
        qos = importlib.import_module("rclpy.qos")
        reliability = (
            qos.ReliabilityPolicy.RELIABLE
            if self.config.ros.reliability(kind) == "reliable"
            else qos.ReliabilityPolicy.BEST_EFFORT
        )
        if kind == "map":
            return qos.QoSProfile(depth=1, reliability=reliability, durability=qos.DurabilityPolicy.TRANSIENT_LOCAL)
        # Images: depth 10. Reliable Fast DDS delivered to a bare subscriber, of each of three 720p cameras at 30 fps
        # (2026-11-23, quiet machine): depth 1-2: 5-7 fps, 5: 23, 10: 28-30, 20: 27-29. A large sample still being
        # reassembled is lost when the next ones claim the history's slots. The encoder takes the newest anyway, so
        # a deeper queue costs memory (at most 10 x 2.7 MB at 720p), not latency.
        return qos.QoSProfile(depth=IMAGE_DEPTH if kind == "images" else 10, reliability=reliability)

    def _create_robot(self, robot: Robot) -> None:
        node = self._node
        name = robot.name
        source = robot.pose.source
        pose_cls = self._msg(*POSE_MESSAGES[source])
        # raw=True: bytes, decoded here as far as the relay needs (relay/backends/ingest.py has the figures).
        if source == "tf":
            on_tf = self._tf_reader(robot)
            for topic, qos in ((robot.pose.topic, "pose"), (robot.pose.topic + "_static", "map")):
                node.create_subscription(pose_cls, topic, on_tf, self._qos(qos), raw=True)
        else:
            node.create_subscription(pose_cls, robot.pose.topic, self._pose_reader(robot), self._qos("pose"), raw=True)
        for sensor in robot.sensors:
            kind = SENSOR_TYPES[sensor.type]
            node.create_subscription(
                self._msg(kind.module, kind.cls),
                sensor.topic,
                lambda m, r=name, s=sensor.name, f=kind.value: self._post(SensorEvent(r, s, f(m), message_stamp(m))),
                self._qos("sensors"),
            )
        if robot.scan_topic is not None:
            node.create_subscription(
                self._msg("sensor_msgs.msg", "LaserScan"),
                robot.scan_topic,
                lambda m, r=name: self._on_scan(r, m),
                self._qos("scan"),
                raw=True,
            )
        if robot.plan_topic is not None:
            # The planner's path (Nav2's global plan, in the map frame): drawn in the twin ahead of the robot.
            node.create_subscription(
                self._msg("nav_msgs.msg", "Path"),
                robot.plan_topic,
                lambda m, r=name: self._post(
                    PathEvent(r, tuple((p.pose.position.x, p.pose.position.y) for p in m.poses))
                ),
                self._qos("sensors"),
            )
        if robot.model_source is not None:
            # robot_state_publisher latches the description (transient local): a late subscriber still gets it.
            node.create_subscription(
                self._msg("std_msgs.msg", "String"),
                robot.model_source.topic,
                lambda m, r=name: self._post(RobotModelEvent(r, str(m.data))),
                self._qos("map"),
            )
        for topic, type_name, callback in self._cloud_topics(robot):
            # Raw: the executor thread hands the bytes on; the intake's thread decodes (relay/backends/cloud_intake.py).
            qos = self._qos("map" if type_name == TF_MESSAGE else "images")
            node.create_subscription(self._msg(*_class(type_name)), topic, callback, qos, raw=True)
        if robot.watchdog_topic is not None:
            # The watchdog (relay/watchdog) forwards fresh commands to cmd_vel and stops the robot without us.
            twist_cls = self._msg("geometry_msgs.msg", "TwistStamped")
            self._cmd_pubs[name] = node.create_publisher(twist_cls, robot.watchdog_topic, self._qos("commands"))
        else:
            twist = ("geometry_msgs.msg", "TwistStamped" if robot.cmd_vel_stamped else "Twist")
            self._cmd_pubs[name] = node.create_publisher(self._msg(*twist), robot.cmd_vel_topic, self._qos("commands"))
        self._goal_pubs[name] = node.create_publisher(
            self._msg("geometry_msgs.msg", "PoseStamped"), robot.goal_topic, self._qos("commands")
        )
        self._arms.create(node, robot, self._qos("commands"), self._qos("sensors"))

    def _map_message(self, data: Any) -> Any:
        return data  # rclpy's message

    def _goal_listened(self, spec: Robot) -> bool | None:
        publisher = self._goal_pubs.get(spec.name)
        return None if publisher is None else publisher.get_subscription_count() > 0

    # -- commands (loop thread) -------------------------------------------------------------------

    def _publish_velocity(self, spec: Robot, linear: float, angular: float, *, stamped: bool, stamp: float) -> None:
        message = self._msg("geometry_msgs.msg", "TwistStamped" if stamped else "Twist")()
        twist = message.twist if stamped else message
        if stamped:
            stamp_header(message.header, stamp)
            message.header.frame_id = spec.pose.base_frame
        twist.linear.x = float(linear)
        twist.angular.z = float(angular)
        self._cmd_pubs[spec.name].publish(message)

    async def send_arm_twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        if not self._arms.moves(robot):
            await super().send_arm_twist(robot, linear, angular)
            return
        self._arms.twist(robot, linear, angular)

    async def send_arm_pose(self, robot: str, pose: str, goal: JointGoal) -> None:
        raise self._arms.refuse(robot, "pose", "trajectory_msgs")

    async def send_gripper(self, robot: str, command: str | float, position: float) -> None:
        raise self._arms.refuse(robot, "gripper", "control_msgs")

    async def stop_arm(self, robot: str) -> None:
        self._arms.stop(robot)

    def _publish_goal(self, spec: Robot, x: float, y: float, yaw: float | None) -> None:
        message = self._msg("geometry_msgs.msg", "PoseStamped")()
        message.header.stamp = self._node.get_clock().now().to_msg()
        message.header.frame_id = spec.pose.map_frame
        message.pose.position.x = float(x)
        message.pose.position.y = float(y)
        # Nav2 needs a valid quaternion; without a requested yaw, keep the identity (facing +x).
        qx, qy, qz, qw = yaw_to_quaternion(yaw if yaw is not None else 0.0)
        message.pose.orientation.x, message.pose.orientation.y = qx, qy
        message.pose.orientation.z, message.pose.orientation.w = qz, qw
        self._goal_pubs[spec.name].publish(message)

    # -- cameras (relay.backends.cameras) ---------------------------------------------------------

    def _subscribe_image(self, camera: Camera, callback: Callable[[Any], None]) -> Any:
        if self._node is None:
            return None
        cls = self._msg("sensor_msgs.msg", "CompressedImage" if camera.compressed else "Image")
        # Raw: the executor thread only reads the stamp; a worker decodes the image it will encode.
        return self._node.create_subscription(cls, camera.topic, callback, self._qos("images"), raw=True)

    def _unsubscribe(self, subscription: Any) -> None:
        if self._node is not None:
            self._node.destroy_subscription(subscription)


def _shut_down(rclpy: Any, spinner: Spinner | None, node: Any, context: Any) -> None:
    """Worker thread: stop the executor, destroy the node, shut its context down."""
    if spinner is not None:
        spinner.stop()
    node.destroy_node()
    if context.ok():
        rclpy.shutdown(context=context)
