"""The half the live backends (``ros``, ``zenoh``) share: the thread crossing, goals and gates, cameras, the map and
the watchdogs' heartbeat. Each backend adds how it reaches the robots (an rclpy node, a Zenoh session).

**The thread boundary.** Messages arrive on another thread (rclpy's executor, Zenoh's callbacks). A callback turns a
message into an immutable event (``relay.fleet.events``) and crosses to the asyncio loop in exactly one place,
:meth:`LiveBackend._post` (the :class:`~relay.backends.ingest.Inbox`: one loop wake-up per batch);
:meth:`LiveBackend._hop` is the same crossing for a call (a camera's finished frame, Nav2's answers, another relay's
estop or lease). Nothing else is shared between the threads, except each camera's
``relay.media.frame_encoder.LatestFrameEncoder``, which guards its own state. Image conversion and JPEG encoding run in
a small worker pool, never on the loop and never on the receiving thread (which must keep draining the network).
"""

from __future__ import annotations

import abc
import asyncio
import concurrent.futures
import contextlib
import threading
import time
from collections.abc import Callable, Coroutine
from typing import Any

from ..config import Camera, FleetConfig, Robot
from ..errors import CommandRejected
from ..fleet.events import Event, EventSink, FrameEvent, PoseEvent
from ..fleet.scan import RateCap
from ..ros.maps import map_event
from ..ros.rosmsg import header_stamp
from ..ros.tf import TfPose
from ..session.protocol import MAX_SCAN_RATE, ErrorCode
from .base import Backend
from .cameras import OnDemandCameras
from .cloud_intake import CloudIntake, cloud_intake, cloud_topics
from .ingest import Inbox, RawDecoder, pose_reader
from .navigation import Navigation, NavTransport
from .raw_readers import Warn, read_scan, read_tf

#: Seconds between heartbeats (std_msgs/Header on ``ros.heartbeat_topic``) while the event loop runs; the
#: watchdog's timeout (the deadman's, 0.5 s by default) spans five of them.
HEARTBEAT_PERIOD = 0.1
#: Seconds a goal waits for its robot's goal topic to have a subscriber (Nav2's bt_navigator), then is refused. DDS
#: delivers a volatile topic's message only to readers it has matched: a fresh clone's run lost the goal a relay
#: sent 0.4 s after it started (the navigator's subscription was matched later), and the robot never moved. Goals run
#: apart from their client's other commands (relay/session/commands.py): the wait holds no estop.
GOAL_LISTENER_WAIT = 5.0
GOAL_LISTENER_POLL = 0.05


class LiveBackend(Backend):
    """Robots that run now, reached from another thread; a subclass connects, publishes and subscribes.

    ``nav`` is the transport of Nav2's action and the watchdogs' gates; it hands what arrives to
    :meth:`_to_navigation`. ``warn`` takes the lines about messages that cannot be read.
    """

    def __init__(self, config: FleetConfig, sink: EventSink, nav: NavTransport, *, warn: Warn) -> None:
        super().__init__(config, sink)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._inbox: Inbox | None = None
        self._decode: RawDecoder | None = None
        self._warn = warn
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=2, thread_name_prefix="jpeg")
        self._tf: dict[str, TfPose] = {}
        self._scan_cap = RateCap(MAX_SCAN_RATE)
        self._cameras = OnDemandCameras(
            config, self._pool, self._hop, sink, self._subscribe_image, self._unsubscribe, self._decode_raw
        )
        # Goals, their outcomes and the watchdogs' gates (relay/backends/navigation.py).
        self._nav = Navigation(config, sink, nav)
        self._tasks: list[asyncio.Task[None]] = []
        #: The robots' own clouds for the 3D map (robots.yaml ``clouds``), once started; decoded on its thread.
        self._clouds: CloudIntake | None = None

    # -- what a live backend adds -----------------------------------------------------------------

    @abc.abstractmethod
    def _connect(self) -> None:
        """Worker thread: reach the robots (node, session), every subscription and publisher declared."""

    @abc.abstractmethod
    def _connected(self) -> bool:
        """Whether there is a node or session to stop."""

    @abc.abstractmethod
    async def _disconnect(self) -> None:
        """Leave the robots: everything undeclared, the node or session closed."""

    @abc.abstractmethod
    def _send_heartbeat(self, when: float) -> None:
        """Publish one heartbeat stamped ``when`` (raises while the link is being rebuilt)."""

    @abc.abstractmethod
    def _publish_velocity(self, spec: Robot, linear: float, angular: float, *, stamped: bool, stamp: float) -> None:
        """Publish a Twist (a TwistStamped when ``stamped``, stamped ``stamp``) on the robot's command topic."""

    @abc.abstractmethod
    def _publish_goal(self, spec: Robot, x: float, y: float, yaw: float | None) -> None:
        """Publish a PoseStamped on the robot's goal topic (no yaw: facing +x)."""

    @abc.abstractmethod
    def _goal_listened(self, spec: Robot) -> bool | None:
        """Whether something subscribes to the robot's goal topic now (None: the transport cannot tell)."""

    @abc.abstractmethod
    def _subscribe_image(self, camera: Camera, callback: Callable[[Any], None]) -> Any:
        """A raw subscription of the camera's images (None while there is no node or session)."""

    @abc.abstractmethod
    def _unsubscribe(self, subscription: Any) -> None: ...

    @abc.abstractmethod
    def _map_message(self, data: Any) -> Any:
        """The map's message from what its subscription received; ValueError when it is not one."""

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._inbox = Inbox(self._loop, self._deliver)
        self._clouds = cloud_intake(self.config, self._post, self._decode_raw)
        await asyncio.to_thread(self._connect)  # failing, the relay exits: the intake's daemon thread with it
        if any(robot.watchdog_topic is not None for robot in self.config.robots):
            self._spawn(self._beat(), "heartbeat")
        self._nav.start()

    def _spawn(self, work: Coroutine[Any, Any, None], what: str) -> None:
        self._tasks.append(asyncio.create_task(work, name=f"{self.name}-{what}"))

    async def stop(self) -> None:
        if not self._connected():
            return
        for task in self._tasks:
            task.cancel()
        for robot in self.config.robots:
            with contextlib.suppress(Exception):  # a lost link: the watchdogs stop the robots
                await self.stop_robot(robot.name)
        await self._nav.close(wait=0.5)  # Nav2's answers to the cancels, while the node or session still runs
        await self._disconnect()
        self._pool.shutdown(wait=False, cancel_futures=True)
        if self._clouds is not None:
            await asyncio.to_thread(self._clouds.stop)

    async def _beat(self) -> None:
        """The heartbeat the watchdogs wait for, published from the event loop: a loop that cannot run (a frozen
        or starved relay) sends none, and every watchdog stops its robot."""
        while True:
            with contextlib.suppress(Exception):  # a node or session being rebuilt (recover): the next beat goes out
                self._send_heartbeat(time.time())
            await asyncio.sleep(HEARTBEAT_PERIOD)

    def ingest_stats(self) -> dict[str, int]:
        """Messages taken from the network into the relay, poses replaced by newer ones before the loop got to them,
        events dropped over the inbox's bound, and the cameras' counts (bench/bench_ros_ingest.py reads these)."""
        inbox = self._inbox.stats() if self._inbox is not None else {"received": 0, "coalesced": 0, "dropped": 0}
        return {**inbox, **self._cameras.stats()}

    # -- the thread boundary ----------------------------------------------------------------------

    def _post(self, event: Event) -> None:
        """THE crossing from another thread to the loop; ``event`` is immutable."""
        if self._inbox is not None:
            self._inbox.put(event)
        if self._clouds is not None and isinstance(event, PoseEvent):
            self._clouds.pose(event)  # every pose, before the inbox keeps only the newest: clouds are placed by them

    def _hop(self, call: Callable[[], None]) -> None:
        """The same crossing for a call: a camera encoder's finished frame, Nav2's answer, another relay's estop."""
        loop = self._loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop closed under a late call (shutdown)
                loop.call_soon_threadsafe(call)

    def _to_navigation(self, call: Callable[[Navigation], None]) -> None:
        """The crossing for what Nav2 and the watchdogs say: ``call`` gets the Navigation on the loop."""
        self._hop(lambda: call(self._nav))

    def _deliver(self, event: Event) -> None:
        """On the loop: the relay's sink, then whether the pose reached a bare goal_pose robot's goal."""
        self.sink(event)
        if isinstance(event, PoseEvent):
            self._nav.pose(event)

    # -- what arrives (receiving thread) ----------------------------------------------------------

    def _decode_raw(self, data: bytes, type_name: str) -> Any:
        """A raw message decoded whole (rosbags); ValueError naming the type when the bytes are not one."""
        if self._decode is None:
            self._decode = RawDecoder()
        return self._decode(data, type_name)

    def _pose_reader(self, robot: Robot) -> Callable[[bytes], None]:
        """The raw callback of the robot's Odometry, PoseStamped or PoseWithCovarianceStamped topic."""
        return pose_reader(robot.name, child_frame=robot.pose.source == "odom", put=self._post, warn=self._warn)

    def _tf_reader(self, robot: Robot) -> Callable[[bytes], None]:
        """The raw callback of the robot's /tf and /tf_static, whose chain map -> odom -> base is its pose."""
        name = robot.name
        self._tf[name] = TfPose(robot.pose.map_frame, robot.pose.odom_frame, robot.pose.base_frame)
        # /tf and /tf_static are two subscribers, and Zenoh may call them back on two of its threads at once:
        # the chain they feed is one robot's, read and written whole.
        lock = threading.Lock()

        def on_tf(data: bytes) -> None:
            with lock:
                self._on_tf(name, data)

        return on_tf

    def _on_tf(self, robot: str, data: bytes) -> None:
        read_tf(robot, self._tf[robot], data, self._decode_raw, self._post, warn=self._warn)

    def _cloud_topics(self, robot: Robot) -> list[tuple[str, str, Callable[[bytes], None]]]:
        """The subscriptions of the robot's clouds (none without robots.yaml's ``cloud``): topic, type, raw callback."""
        return [] if self._clouds is None else cloud_topics(robot, self._clouds, self._decode_raw)

    def cloud_health(self) -> dict[str, object]:  # /healthz's ``clouds``
        return {} if self._clouds is None else self._clouds.health()

    def _on_scan(self, robot: str, data: bytes) -> None:
        read_scan(robot, self._scan_cap, data, self._decode_raw, self._post, warn=self._warn)

    def _on_map(self, data: Any) -> None:
        topic = self.config.ros.map_topic
        try:
            message = self._map_message(data)
            self._post(map_event(message, header_stamp(message.header), topic))
        except ValueError as exc:
            self._warn("%s: %s", topic, exc)

    # -- commands (loop thread) -------------------------------------------------------------------

    def _robot(self, name: str) -> Robot:
        robot = self.config.robot(name)
        assert robot is not None
        return robot

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        spec = self._robot(robot)
        # The watchdog judges a command's age by this stamp: the time the operator's command reached the relay.
        when = time.time() if stamp is None else stamp
        stamped = spec.cmd_vel_stamped or spec.watchdog_topic is not None
        self._publish_velocity(spec, linear, angular, stamped=stamped, stamp=when)
        if linear != 0.0 or angular != 0.0:
            self._nav.teleop(robot)

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        spec = self._robot(robot)
        await self._nav.before_goal(robot)  # a cancel still in flight would cancel this goal too
        if not await self._goal_listener(spec, current) or not current():
            return
        self._publish_goal(spec, x, y, yaw)
        self._nav.sent(robot, (x, y, yaw))

    async def _goal_listener(self, spec: Robot, current: Callable[[], bool]) -> bool:
        """Wait until the robot's goal topic has a subscriber; False when the goal was overtaken meanwhile, refused
        when none came within GOAL_LISTENER_WAIT."""
        waited = 0.0
        while self._goal_listened(spec) is False:
            if not current():
                return False
            if waited >= GOAL_LISTENER_WAIT:
                raise CommandRejected(
                    ErrorCode.UNREACHABLE,
                    f"{spec.name}/goal_pose: nothing subscribes to {spec.goal_topic} (waited {GOAL_LISTENER_WAIT:g} s):"
                    " is the robot's navigator (Nav2's bt_navigator) running, in this ROS domain?",
                )
            await asyncio.sleep(GOAL_LISTENER_POLL)
            waited += GOAL_LISTENER_POLL
        return True

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

    # -- cameras (relay.backends.cameras) ---------------------------------------------------------

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        self._cameras.set_stream(robot, camera, fps)

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:
        self._cameras.set_jpeg(robot, camera, wanted)

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        return await self._cameras.snapshot(robot, camera)
