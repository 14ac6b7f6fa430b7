"""Recorded messages to events, per topic: the handlers each bag's reader thread applies."""

from __future__ import annotations

import collections
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from ...config import Camera, Sensor
from ...fleet.events import (
    Event,
    MapEvent,
    PoseEvent,
    SensorEvent,
)
from ...fleet.scan import scan_event
from ...ros.maps import map_event
from ...ros.rosmsg import (
    SENSOR_TYPES,
    message_stamp,
    pose_event,
)
from ..cloud_intake import CloudIntake
from .binding import BagPlan, RobotTopics
from .tf_chain import _TfChain

logger = logging.getLogger(__name__)

#: Type definitions for bags that store none (rosbag2 sqlite3 before Iron): ROS 2 Humble's.
DEFAULT_TYPESTORE = "ros2_humble"


@dataclass(frozen=True, slots=True)
class _Image:
    """A decoded camera image waiting for a JPEG encode (only if someone looks)."""

    robot: str
    camera: str
    compressed: bool
    stamp: float
    message: Any  # a rosbags sensor_msgs Image or CompressedImage; never mutated


@dataclass(frozen=True, slots=True)
class _Cloud:
    """A recorded cloud (PointCloud2 or depth Image), for relay/backends/cloud_intake.py at its playback time."""

    robot: str
    name: str  # its source's, robots.yaml ``clouds``
    message: Any  # rosbags' message; never mutated


class StaticSink(Protocol):
    def add_static(self, message: Any) -> None: ...


class _CloudStatics:
    """/tf_static to the cloud intake's frames of one robot (beside its _TfChain, with pose source tf)."""

    def __init__(self, clouds: CloudIntake, robot: str) -> None:
        self.clouds, self.robot = clouds, robot

    def add_static(self, message: Any) -> None:
        self.clouds.transforms(self.robot, message)


Payload = Event | _Image | _Cloud
Key = tuple[str, ...]
Handler = Callable[[Any, float], "Payload | None"]


@dataclass(frozen=True, slots=True)
class _Item:
    position: float  # seconds from the bag's first message
    payload: Payload | None  # None marks the end of the bag
    size: int = 0  # bytes of image data it holds


def _pose_handler(robot: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return pose_event(robot, message, message_stamp(message, log_time))

    return handle


def _sensor_handler(robot: str, sensor: Sensor) -> Handler:
    extract = SENSOR_TYPES[sensor.type].value

    def handle(message: Any, log_time: float) -> Payload:
        return SensorEvent(robot, sensor.name, extract(message), message_stamp(message, log_time))

    return handle


def _scan_handler(robot: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return scan_event(robot, message_stamp(message, log_time), message)

    return handle


def _camera_handler(robot: str, camera: Camera) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return _Image(robot, camera.name, camera.compressed, message_stamp(message, log_time), message)

    return handle


def _cloud_handler(robot: str, name: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return _Cloud(robot, name, message)

    return handle


def _camera_info_handler(clouds: CloudIntake, robot: str, name: str) -> Handler:
    """A depth source's CameraInfo, kept by the intake as the bag is read (no payload: nothing to play)."""

    def handle(message: Any, log_time: float) -> None:
        clouds.camera_info(robot, name, message)

    return handle


def _map_handler(topic: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return map_event(message, message_stamp(message, log_time), topic)

    return handle


class _Decoder:
    """Reader thread: routes each message of a plan's topics to the handlers that turn it into payloads."""

    def __init__(self, plan: BagPlan, name: str, clouds: CloudIntake | None = None) -> None:
        self.name = name
        self.clouds = clouds
        self.routes: dict[str, list[tuple[Key, Handler]]] = collections.defaultdict(list)
        self.statics: dict[str, list[StaticSink]] = collections.defaultdict(list)
        self.chains: list[_TfChain] = []
        self._warned: set[str] = set()
        self.robots = [topics.robot.name for topics in plan.robots]
        for topics in plan.robots:
            robot = topics.robot.name
            if topics.robot.pose.source == "tf":
                chain = _TfChain(topics.robot)
                self.chains.append(chain)
                self.routes[topics.pose].append((("pose", robot), chain.feed))
                if topics.tf_static is not None:
                    self.statics[topics.tf_static].append(chain)
            else:
                self.routes[topics.pose].append((("pose", robot), _pose_handler(robot)))
            if topics.scan is not None:
                self.routes[topics.scan].append((("scan", robot), _scan_handler(robot)))
            for sensor, topic in topics.sensors:
                self.routes[topic].append((("sensor", robot, sensor.name), _sensor_handler(robot, sensor)))
            for camera, topic in topics.cameras:
                self.routes[topic].append((("image", robot, camera.name), _camera_handler(robot, camera)))
            if clouds is not None:
                self._add_clouds(clouds, topics)
        if plan.map_topic is not None:
            self.routes[plan.map_topic].append((("map",), _map_handler(plan.map_topic)))

    def _add_clouds(self, clouds: CloudIntake, topics: RobotTopics) -> None:
        """Routes of a robot's clouds (payloads played at their time) and CameraInfos (kept by the intake now)."""
        robot = topics.robot.name
        for source, topic, info in topics.clouds:
            self.routes[topic].append((("cloud", robot, source.name), _cloud_handler(robot, source.name)))
            if info is not None:
                keep = _camera_info_handler(clouds, robot, source.name)
                self.routes[info].append((("camera_info", robot, source.name), keep))
        if topics.cloud_static is not None:
            self.statics[topics.cloud_static].append(_CloudStatics(clouds, robot))

    def reset(self) -> None:
        for chain in self.chains:
            chain.reset()
        if self.clouds is not None:
            self.clouds.forget_poses(self.robots)

    def warn_once(self, topic: str, what: str, exc: BaseException) -> None:
        if topic not in self._warned:
            self._warned.add(topic)
            logger.warning("%s: %s %s: %s; such messages are skipped", self.name, what, topic, exc)

    def decode(self, topic: str, message: Any, log_time: float) -> list[tuple[Key, Payload]]:
        out: list[tuple[Key, Payload]] = []
        for key, handler in self.routes.get(topic, ()):
            try:
                payload = handler(message, log_time)
            except Exception as exc:  # a malformed message must not end the replay
                self.warn_once(topic, "cannot use a message of", exc)
                continue
            if payload is not None:
                out.append((key, payload))
                if isinstance(payload, PoseEvent) and self.clouds is not None:
                    self.clouds.pose(payload)  # read ahead of playback: the poses around a cloud's stamp are known
        return out


def _size(payload: Payload) -> int:
    if isinstance(payload, _Image | _Cloud):
        return len(payload.message.data)
    if isinstance(payload, MapEvent):
        return int(payload.grid.occupied.size)
    return 0


def _first_string(path: Path, topic: str) -> str | None:
    """The first std_msgs/String recorded on ``topic`` (worker thread)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([path], default_typestore=get_typestore(Stores(DEFAULT_TYPESTORE))) as reader:
        connections = [c for c in reader.connections if c.topic == topic]
        for connection, _, raw in reader.messages(connections=connections):
            message: Any = reader.deserialize(raw, connection.msgtype)
            return str(message.data)
    return None
