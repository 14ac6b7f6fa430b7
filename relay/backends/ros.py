"""The ``ros`` backend: a live ROS 2 graph through rclpy. The only module that imports rclpy.

rclpy is imported lazily when the backend is created, so the relay runs without ROS for the other
backends; without it, this backend refuses to start with one line saying how to get it.

**The thread boundary.** One executor thread spins the node. Callbacks run there, turn a message into an
immutable event (``relay.events``) and cross to the asyncio loop in exactly one place, :meth:`RosBackend._post`
(the :class:`~relay.backends.ros_ingest.Inbox`: one loop wake-up per batch; :meth:`RosBackend._hop` is the
same crossing for a finished camera frame).
Nothing else is shared between the threads, except each camera's ``relay.frame_encoder.LatestFrameEncoder``,
which guards its own state. Image conversion and JPEG encoding run in a small worker pool, never on the
loop and never on the executor thread (which must keep draining DDS).

Executor and decoding: every high-rate topic raw, poses decoded by hand, TF, scans and images by rosbags,
the EventsExecutor spun from its thread until a future is done (relay/backends/ros_ingest.py says why, with
the figures; bench/bench_ros_ingest.py measures it against bare subscribers every run). Low-rate topics
(sensors, paths, the map, robot descriptions) keep rclpy's messages.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import importlib
import logging
import os
import time
from collections.abc import Callable
from typing import Any

from ..config import Camera, FleetConfig, Robot
from ..errors import BackendUnavailable
from ..events import Event, EventSink, FrameEvent, PathEvent, PoseEvent, RobotModelEvent, SensorEvent
from ..geometry import yaw_to_quaternion
from ..maps import map_event
from ..occupancy import OccupancyGrid
from ..protocol import MAX_SCAN_RATE
from ..ros_env import load_rclpy
from ..rosmsg import (
    POSE_MESSAGES,
    SENSOR_TYPES,
    header_stamp,
    message_stamp,
)
from ..scan import RateCap
from ..tf import TfPose
from . import dds_profile
from .base import Backend
from .navigation import Navigation
from .raw_readers import read_scan, read_tf
from .ros_cameras import RosCameras
from .ros_ingest import Inbox, LoopCrossing, RawDecoder, Spinner, pose_reader
from .ros_nav2 import RosNav2, needed_messages

logger = logging.getLogger(__name__)

#: Seconds between heartbeats (std_msgs/Header on ``ros.heartbeat_topic``) while the event loop runs; the
#: watchdog's timeout (the deadman's, 0.5 s by default) spans five of them.
HEARTBEAT_PERIOD = 0.1
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
    for module, cls in (
        ("geometry_msgs.msg", "Twist"),
        ("geometry_msgs.msg", "TwistStamped"),
        ("geometry_msgs.msg", "PoseStamped"),
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
                    " (the PyPI ROS wheels do not include it): use pose source odom, amcl_pose or pose "
                    "in robots.yaml, or source a ROS 2 installation that has tf2_msgs"
                )
            problems.append(f"{who} needs the message package {package}, which is not installed{hint}")
    if problems:
        raise BackendUnavailable("; ".join(problems))
    return classes


class RosBackend(LoopCrossing, Backend):
    name = "ros"

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        super().__init__(config, sink)
        # Importing rclpy and the message packages takes a few hundred milliseconds: ``start`` does it in
        # a worker thread, and a missing package still stops the relay before it serves anything.
        self._rclpy: Any = None
        self._messages: dict[str, Any] = {}
        self._loop: asyncio.AbstractEventLoop | None = None
        self._context: Any = None
        self._node: Any = None
        self._spinner: Spinner | None = None
        self._inbox: Inbox | None = None
        self._decode: RawDecoder | None = None
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=2, thread_name_prefix="jpeg")
        self._cmd_pubs: dict[str, Any] = {}
        self._goal_pubs: dict[str, Any] = {}
        self._tf: dict[str, TfPose] = {}
        self._scan_cap = RateCap(MAX_SCAN_RATE)
        self._cameras = RosCameras(
            config, self._pool, self._hop, self.sink, self._subscribe_image, self._destroy, self._decode_raw
        )
        # Goals, their outcomes and the watchdogs' gates (relay/backends/navigation.py, shared with zenoh).
        self._nav2 = RosNav2(config, self._hop, self._decode_raw)
        self._nav = self._nav2.navigation = Navigation(config, sink, self._nav2)
        self._grid: OccupancyGrid | None = None
        self._heartbeat_pub: Any = None
        self._heartbeat_task: asyncio.Task[None] | None = None
        #: The Fast DDS profile in effect (dds_profile.apply), for /healthz.
        self.dds_profile = ""

    def _msg(self, module: str, cls: str) -> Any:
        return self._messages[f"{module}.{cls}"]

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._inbox = Inbox(self._loop, self._deliver)
        await asyncio.to_thread(self._start_node)
        if self._heartbeat_pub is not None:
            self._heartbeat_task = asyncio.create_task(self._beat(), name="ros-heartbeat")
        self._nav.start()
        logger.info(
            "ros backend: node xr_relay in ROS_DOMAIN_ID %s, %d robots, %s executor",
            os.environ.get("ROS_DOMAIN_ID", "0"),
            len(self.config.robots),
            self._spinner.kind if self._spinner is not None else "no",
        )

    def _start_node(self) -> None:
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

    def health(self) -> dict[str, object]:
        return {"dds_profile": self.dds_profile}

    def _executor_failed(self, why: str) -> None:
        if self._node is not None:
            self.failure = why

    def ingest_stats(self) -> dict[str, int]:
        """Messages taken from DDS into the relay, poses replaced by newer ones before the loop got to them,
        events dropped over the inbox's bound (bench/bench_ros_ingest.py reads these)."""
        inbox = self._inbox.stats() if self._inbox is not None else {"received": 0, "coalesced": 0, "dropped": 0}
        return {**inbox, **self._cameras.stats()}

    async def recover(self) -> None:
        """Re-create the node, its subscriptions and publishers, and the executor thread."""
        old_spinner, old_node, old_context = self._spinner, self._node, self._context

        def rebuild() -> None:
            with contextlib.suppress(Exception):  # the old node is already half gone: best effort
                if old_spinner is not None:
                    old_spinner.stop()
                old_node.destroy_node()
                if old_context.ok():
                    self._rclpy.shutdown(context=old_context)
            self._cameras.forget_subscriptions()
            self._start_node()

        await asyncio.to_thread(rebuild)
        self._cameras.resubscribe()
        self.failure = None
        logger.warning("ros backend recovered: node and subscriptions re-created")

    async def _beat(self) -> None:
        """The heartbeat the watchdogs wait for, published from the event loop: a loop that cannot run (a frozen
        or starved relay) sends none, and every watchdog stops its robot."""
        header = self._msg("std_msgs.msg", "Header")()
        header.frame_id = "xr_relay"
        while True:
            when = time.time()
            header.stamp.sec, header.stamp.nanosec = int(when), int((when - int(when)) * 1e9)
            if self._heartbeat_pub is not None and self._node is not None:
                with contextlib.suppress(Exception):  # a node being rebuilt (recover): the next beat goes out
                    self._heartbeat_pub.publish(header)
            await asyncio.sleep(HEARTBEAT_PERIOD)

    async def stop(self) -> None:
        if self._node is None:
            return
        if self._heartbeat_task is not None:
            self._heartbeat_task.cancel()
        for robot in self.config.robots:
            await self.stop_robot(robot.name)
        await self._nav.close(wait=0.5)  # Nav2's answers to the cancels, while the node still spins
        spinner, node, context = self._spinner, self._node, self._context
        self._node = None

        def shutdown() -> None:
            if spinner is not None:
                spinner.stop()
            node.destroy_node()
            if context.ok():
                self._rclpy.shutdown(context=context)

        await asyncio.to_thread(shutdown)
        self._pool.shutdown(wait=False, cancel_futures=True)

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
        # raw=True: bytes, decoded here as far as the relay needs (relay/backends/ros_ingest.py has the figures).
        if source == "tf":
            self._tf[name] = TfPose(robot.pose.map_frame, robot.pose.odom_frame, robot.pose.base_frame)
            for topic, qos in ((robot.pose.topic, "pose"), (robot.pose.topic + "_static", "map")):
                node.create_subscription(pose_cls, topic, lambda m, r=name: self._on_tf(r, m), self._qos(qos), raw=True)
        else:
            on_pose = pose_reader(name, child_frame=source == "odom", put=self._post)
            node.create_subscription(pose_cls, robot.pose.topic, on_pose, self._qos("pose"), raw=True)
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

    # -- the thread boundary ----------------------------------------------------------------------

    def _deliver(self, event: Event) -> None:
        """On the loop: the relay's sink, then whether the pose reached a bare goal_pose robot's goal."""
        self.sink(event)
        if isinstance(event, PoseEvent):
            self._nav.pose(event)

    # -- callbacks (executor thread) --------------------------------------------------------------

    def _decode_raw(self, data: bytes, type_name: str) -> Any:
        """A raw message decoded whole (rosbags); ValueError naming the type when the bytes are not one."""
        if self._decode is None:
            self._decode = RawDecoder()
        return self._decode(data, type_name)

    def _on_tf(self, robot: str, data: bytes) -> None:
        read_tf(robot, self._tf[robot], data, self._decode_raw, self._post)

    def _on_scan(self, robot: str, data: bytes) -> None:
        read_scan(robot, self._scan_cap, data, self._decode_raw, self._post)

    def _on_map(self, message: Any) -> None:
        try:
            self._post(map_event(message, header_stamp(message.header), self.config.ros.map_topic))
        except ValueError as exc:
            logger.warning("%s: %s", self.config.ros.map_topic, exc)

    # -- commands (loop thread) -------------------------------------------------------------------

    def _robot(self, name: str) -> Robot:
        robot = self.config.robot(name)
        assert robot is not None
        return robot

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        spec = self._robot(robot)
        stamped = spec.cmd_vel_stamped or spec.watchdog_topic is not None
        message = self._msg("geometry_msgs.msg", "TwistStamped" if stamped else "Twist")()
        twist = message.twist if stamped else message
        if stamped:
            # The watchdog judges a command's age by this stamp: the time the operator's command reached the relay.
            when = time.time() if stamp is None else stamp
            message.header.stamp.sec = int(when)
            message.header.stamp.nanosec = int((when - int(when)) * 1e9)
            message.header.frame_id = spec.pose.base_frame
        twist.linear.x = float(linear)
        twist.angular.z = float(angular)
        self._cmd_pubs[robot].publish(message)
        if linear != 0.0 or angular != 0.0:
            self._nav.teleop(robot)

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        spec = self._robot(robot)
        await self._nav.before_goal(robot)  # a cancel still in flight would cancel this goal too
        if not current():
            return
        message = self._msg("geometry_msgs.msg", "PoseStamped")()
        message.header.stamp = self._node.get_clock().now().to_msg()
        message.header.frame_id = spec.pose.map_frame
        message.pose.position.x = float(x)
        message.pose.position.y = float(y)
        # Nav2 needs a valid quaternion; without a requested yaw, keep the identity (facing +x).
        qx, qy, qz, qw = yaw_to_quaternion(yaw if yaw is not None else 0.0)
        message.pose.orientation.x, message.pose.orientation.y = qx, qy
        message.pose.orientation.z, message.pose.orientation.w = qz, qw
        self._goal_pubs[robot].publish(message)
        self._nav.sent(robot, (x, y, yaw))

    async def cancel(self, robot: str) -> None:
        # Nav2's goals are cancelled (the request sent, not awaited) and the watchdog holds autonomy; then zero.
        self._nav.stop(robot, "cancelled")
        await self.send_velocity(robot, 0.0, 0.0)

    async def estop_robot(self, robot: str) -> None:
        # The zero first (the path the estop-latency test times), then the gate's latch and Nav2's cancel, sent
        # and not awaited: nothing here waits for the robot.
        try:
            await self.send_velocity(robot, 0.0, 0.0)
        finally:
            self._nav.stop(robot, "emergency stop", "estop")

    def release_estop(self, robot: str) -> None:
        self._nav.release(robot)

    def map_grid(self) -> OccupancyGrid | None:
        return None  # the live /map reaches the relay as a MapEvent

    # -- cameras (relay.backends.ros_cameras) -----------------------------------------------------

    def _subscribe_image(self, camera: Camera, callback: Callable[[Any], None]) -> Any:
        if self._node is None:
            return None
        cls = self._msg("sensor_msgs.msg", "CompressedImage" if camera.compressed else "Image")
        # Raw: the executor thread only reads the stamp; a worker decodes the image it will encode.
        return self._node.create_subscription(cls, camera.topic, callback, self._qos("images"), raw=True)

    def _destroy(self, subscription: Any) -> None:
        if self._node is not None:
            self._node.destroy_subscription(subscription)

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        self._cameras.set_stream(robot, camera, fps)

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:
        self._cameras.set_jpeg(robot, camera, wanted)

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        return await self._cameras.snapshot(robot, camera)
