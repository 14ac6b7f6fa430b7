"""The ``zenoh`` backend: ROS 2 robots over a Zenoh network, with no ROS install (docs/zenoh.md).

Robots speak rmw_zenoh (keys ``<domain>/<topic>/<type>/<hash>``) or sit behind zenoh-bridge-ros2dds (keys
``<topic>``); relay/backends/zenoh_keys.py has the layout. Samples are CDR, read by the same code as the ``ros``
backend's raw subscriptions: poses by hand (relay/ros/cdr.py), TF, scans, images and the low-rate types by rosbags
(relay/backends/raw_readers.py, ingest.RawDecoder); commands are CDR built by rosbags
(relay/backends/cdr_encode.py) and carry rmw_zenoh's attachment (relay/backends/zenoh_topics.py).

**The thread boundary.** Zenoh calls back on its own threads. A callback decodes the sample into an immutable
event and hands it to the loop as relay/backends/live.py says (the same batching Inbox as the ``ros`` backend's);
a camera's finished frame and the fleet's estops and leases cross in its ``_hop``.

**Subscriptions** are one per topic, ``<domain>/<topic>/*/*`` (any type and hash, the type checked per sample), not
one per robot (``<domain>/<robot>/**``): a robot-wide wildcard would also pull every camera's images across the
network whether anyone watches or not; cameras are subscribed only while streamed or snapshot (cameras.py).

**The link.** A client session has one router; while it has none (the router went away), ``failure`` says so and
Zenoh reconnects by itself (the session's subscriptions and tokens are re-declared by Zenoh); ``recover`` clears
the failure once the router is back, or opens a new session if this one was closed. Several relays share estops and
leases through relay/backends/zenoh_fleet.py.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from typing import Any

from ..arm.named import JointGoal
from ..cli.options import ZenohOptions
from ..config import Camera, FleetConfig, Robot
from ..control.fleet_peer import FleetPeer
from ..errors import BackendUnavailable
from ..fleet.events import Event, EventSink, PoseEvent
from ..logs.budget import BudgetedLog
from ..ros.rosmsg import MAP_TYPE, POSE_TYPES, SCAN_TYPE, image_type
from .base import Vec3
from .cdr_encode import HEADER, POSE_STAMPED, TWIST, TWIST_STAMPED, CommandEncoder
from .cloud_intake import TF_MESSAGE
from .ingest import RawDecoder
from .live import LiveBackend
from .raw_readers import PATH_TYPE, STRING_TYPE, read_model, read_path, read_sensor
from .zenoh_arms import ZenohArms
from .zenoh_fleet import ZenohFleet
from .zenoh_keys import topic_selector
from .zenoh_nav2 import ZenohNav2
from .zenoh_session import ZenohSettings, connected, load_zenoh, open_session, settings
from .zenoh_topics import KeyWarnings, ZenohPublisher, ZenohTopics

logger = logging.getLogger(__name__)

#: Seconds between two looks at the session's router.
LINK_PERIOD = 0.5
#: Seconds after start when a robot whose pose key has had no sample is named in the log (a wrong topic or domain
#: matches no publisher, and Zenoh says nothing about it).
SILENT_AFTER = 5.0


class ZenohBackend(LiveBackend):
    """The robots of a Zenoh network: one client session, its publishers of commands, the fleet's other relays."""

    name = "zenoh"

    def __init__(self, config: FleetConfig, sink: EventSink, options: ZenohOptions | None = None) -> None:
        self.settings: ZenohSettings = settings(config.zenoh, options or ZenohOptions())
        # Goals, their outcomes and the watchdogs' gates (relay/backends/navigation.py, shared with ros).
        self._nav2 = ZenohNav2(config, self.settings, self._hop, self._to_navigation)
        #: Lines about what others send (robots' samples, other relays'): rate-limited, whatever they send.
        self._peer_log = BudgetedLog(logger, "zenoh: lines about samples received")
        super().__init__(config, sink, self._nav2, warn=self._peer_log.warning)
        self._zenoh: Any = None
        self._session: Any = None
        self._topics: ZenohTopics | None = None
        self._encode: CommandEncoder | None = None
        self._store: Any = None
        self._entities: list[Any] = []
        self._cmd: dict[str, ZenohPublisher] = {}
        self._goal: dict[str, ZenohPublisher] = {}
        self._arms = ZenohArms(self._decode_raw, self._post, self._peer_log.warning)
        self._heartbeat: ZenohPublisher | None = None
        self._fleet = ZenohFleet(
            self.settings.fleet_key,
            self.settings.relay_id,
            self._hop,
            [robot.name for robot in config.robots],
            lease_timeout=self.settings.peer_lease_timeout,
            log=self._peer_log,
        )
        self._warn_once = KeyWarnings(self._peer_log)
        #: Robots whose pose has arrived at least once.
        self._heard: set[str] = set()

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self) -> None:
        await super().start()
        self._spawn(self._watch_link(), "link")
        self._spawn(self._fleet.run(), "fleet")
        self._spawn(self._name_silent_keys(), "silent")
        s = self.settings
        logger.info(
            "zenoh backend: %s mode, connected to %s, %s keys (domain %d), relay id %s, %d robots",
            s.mode, s.where(), s.keys, s.domain, self._fleet.relay_id, len(self.config.robots),
        )  # fmt: skip

    def _connect(self) -> None:
        """Worker thread: import zenoh and rosbags' types, open the session, declare everything."""
        self._zenoh = load_zenoh()
        if self._encode is None:
            from ..ros.nav2_types import typestore

            self._decode = RawDecoder()
            self._store = typestore()
            self._encode = CommandEncoder(self._store)
        self._session = open_session(self.settings)
        self._declare()

    def _connected(self) -> bool:
        return self._session is not None

    def _declare(self) -> None:
        assert self._encode is not None
        topics = self._topics = ZenohTopics(self._zenoh, self._session, self.settings, self._encode, self._warn_once)
        for robot in self.config.robots:
            self._declare_robot(topics, robot)
        self._entities.append(topics.subscribe("map", self.config.ros.map_topic, MAP_TYPE, self._on_map, history=True))
        if any(robot.watchdog_topic is not None for robot in self.config.robots):
            self._heartbeat = topics.publisher(self.config.ros.heartbeat_topic, HEADER)
        latched = lambda topic, type_name: topics.publisher(topic, type_name, latched=True)  # noqa: E731
        self._entities += self._nav2.declare(topics.query, self._store, self._decode_raw, topics.subscribe, latched)
        self._fleet.open(self._zenoh, self._session)

    def _close_session(self) -> None:
        """Worker thread: undeclare everything and close the session (best effort: it may be half gone)."""
        self._fleet.close()
        self._nav2.close()
        for entity in [*self._entities, *self._cmd.values(), *self._goal.values()]:
            with contextlib.suppress(Exception):
                entity.undeclare()
        if self._heartbeat is not None:
            self._heartbeat.undeclare()
        self._entities, self._cmd, self._goal, self._heartbeat, self._topics = [], {}, {}, None, None
        self._arms.forget()
        self._cameras.forget_subscriptions()
        if self._session is not None:
            with contextlib.suppress(Exception):
                self._session.close()

    async def _disconnect(self) -> None:
        await asyncio.to_thread(self._close_session)
        self._session = None

    async def _watch_link(self) -> None:
        """Report a lost router as the backend's failure (Zenoh reconnects; ``recover`` notices)."""
        while True:
            await asyncio.sleep(LINK_PERIOD)
            session = self._session
            if session is None or self.failure is not None:
                continue
            if session.is_closed() or not connected(session):
                self.failure = f"lost the Zenoh router at {self.settings.where()}; reconnecting"

    def silent(self) -> dict[str, str]:
        """Robots whose pose key has had no sample yet, with the key expression they wait on."""
        s = self.settings
        return {
            robot.name: topic_selector(s.keys, s.domain, robot.pose.topic)
            for robot in self.config.robots
            if robot.name not in self._heard
        }

    async def _name_silent_keys(self) -> None:
        await asyncio.sleep(SILENT_AFTER)
        for robot, selector in self.silent().items():
            logger.warning(
                "zenoh: %s: no pose sample on %s in %.0f s: no publisher matches that key (is robots.yaml's pose topic "
                "right, and the domain %d, and keys: %s?)",
                robot, selector, SILENT_AFTER, self.settings.domain, self.settings.keys,
            )  # fmt: skip

    async def recover(self) -> None:
        session = self._session
        if session is not None and not session.is_closed():
            if connected(session):
                self.failure = None
                logger.warning("zenoh backend recovered: the router at %s is back", self.settings.where())
            return
        await asyncio.to_thread(self._close_session)
        try:
            self._session = await asyncio.to_thread(open_session, self.settings)
        except BackendUnavailable as exc:
            self.failure = str(exc)
            return
        await asyncio.to_thread(self._declare)
        self._cameras.resubscribe()
        self.failure = None
        logger.warning("zenoh backend recovered: a new session to %s", self.settings.where())

    def fleet_peer(self) -> FleetPeer:
        return self._fleet

    def health(self) -> dict[str, object]:
        s, session = self.settings, self._session
        link = session is not None and not session.is_closed() and connected(session)
        return {
            "zenoh": {
                "mode": s.mode, "connect": list(s.connect), "keys": s.keys, "domain": s.domain,
                "relay_id": self._fleet.relay_id, "connected": link, "silent": self.silent(),
                "fleet": self._fleet.health(),
            },
            **self.cloud_health(),
        }  # fmt: skip

    def _send_heartbeat(self, when: float) -> None:
        assert self._encode is not None
        if self._heartbeat is not None:
            self._heartbeat.put(self._encode.header(when, "xr_relay"))

    # -- declarations (worker thread) -------------------------------------------------------------

    def _declare_robot(self, topics: ZenohTopics, robot: Robot) -> None:
        name, source = robot.name, robot.pose.source
        add, subscribe = self._entities.append, topics.subscribe
        if source == "tf":
            on_tf = self._tf_reader(robot)
            add(subscribe(f"{name} tf", robot.pose.topic, POSE_TYPES["tf"], on_tf))
            add(subscribe(f"{name} tf_static", robot.pose.topic + "_static", POSE_TYPES["tf"], on_tf))
        else:
            add(subscribe(f"{name} pose", robot.pose.topic, POSE_TYPES[source], self._pose_reader(robot)))
        for sensor in robot.sensors:
            on_sensor = self._sensor(name, sensor.name, sensor.type)
            add(subscribe(f"{name} sensor {sensor.name}", sensor.topic, sensor.type, on_sensor))
        if robot.scan_topic is not None:
            add(subscribe(f"{name} scan", robot.scan_topic, SCAN_TYPE, lambda d: self._on_scan(name, d)))
        if robot.plan_topic is not None:
            on_plan = lambda d: read_path(name, d, self._decode_raw, self._post, warn=self._warn)  # noqa: E731
            add(subscribe(f"{name} plan", robot.plan_topic, PATH_TYPE, on_plan))
        if robot.model_source is not None:
            on_model = lambda d: read_model(name, d, self._decode_raw, self._post, warn=self._warn)  # noqa: E731
            what = f"{name} robot description"
            add(subscribe(what, robot.model_source.topic, STRING_TYPE, on_model, history=True))
        for topic, type_name, callback in self._cloud_topics(robot):
            add(subscribe(f"{name} cloud {topic}", topic, type_name, callback, history=type_name == TF_MESSAGE))
        # Through its watchdog (always stamped) when it has one, else straight to its cmd_vel.
        twist = TWIST_STAMPED if robot.watchdog_topic is not None or robot.cmd_vel_stamped else TWIST
        self._cmd[name] = topics.publisher(robot.watchdog_topic or robot.cmd_vel_topic, twist)
        self._goal[name] = topics.publisher(robot.goal_topic, POSE_STAMPED)
        self._entities += self._arms.declare(topics, robot)

    def _sensor(self, robot: str, sensor: str, type_name: str) -> Callable[[bytes], None]:
        def on_bytes(data: bytes) -> None:
            read_sensor(robot, sensor, type_name, data, self._decode_raw, self._post, warn=self._warn)

        return on_bytes

    def _subscribe_image(self, camera: Camera, callback: Callable[[Any], None]) -> Any:
        topics = self._topics
        if topics is None:
            return None
        return topics.subscribe(f"camera {camera.name}", camera.topic, image_type(camera.compressed), callback)

    def _unsubscribe(self, subscription: Any) -> None:
        with contextlib.suppress(Exception):
            subscription.undeclare()

    # -- what arrives -----------------------------------------------------------------------------

    def _deliver(self, event: Event) -> None:
        if isinstance(event, PoseEvent):
            self._heard.add(event.robot)
        super()._deliver(event)

    def _map_message(self, data: Any) -> Any:
        return self._decode_raw(data, MAP_TYPE)

    def _goal_listened(self, spec: Robot) -> bool | None:
        publisher = self._goal.get(spec.name)
        return None if publisher is None else publisher.matched()

    # -- commands (loop thread) -------------------------------------------------------------------

    def _send(self, publishers: dict[str, ZenohPublisher], robot: str, payload: bytes) -> None:
        publisher = publishers.get(robot)
        if publisher is None:
            raise BackendUnavailable(f"zenoh: no session to {self.settings.where()}: {robot} cannot be commanded")
        publisher.put(payload)

    def _publish_velocity(self, spec: Robot, linear: float, angular: float, *, stamped: bool, stamp: float) -> None:
        assert self._encode is not None
        payload = self._encode.twist(linear, angular, stamped=stamped, stamp=stamp, frame=spec.pose.base_frame)
        self._send(self._cmd, spec.name, payload)

    async def send_arm_twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        self._arms.twist(robot, linear, angular)

    async def send_arm_pose(self, robot: str, pose: str, goal: JointGoal) -> None:
        self._arms.pose(robot, goal)

    async def send_gripper(self, robot: str, command: str | float, position: float) -> None:
        self._arms.gripper(robot, position)

    async def stop_arm(self, robot: str) -> None:
        self._arms.stop(robot)

    def _publish_goal(self, spec: Robot, x: float, y: float, yaw: float | None) -> None:
        assert self._encode is not None
        payload = self._encode.goal(x, y, yaw, stamp=time.time(), frame=spec.pose.map_frame)
        self._send(self._goal, spec.name, payload)
