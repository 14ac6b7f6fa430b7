"""The ``bag`` backend: rosbag2 recordings (sqlite3 or MCAP) replayed with ``rosbags``; no ROS needed.

**Which robot a bag plays as.** ``--bag ROBOT=PATH`` binds a bag to a robot of robots.yaml. An unbound bag
plays as every robot whose own namespaced topics it contains (``/robot1/odom``: a recording of the fleet, as
``xr-relay record`` makes); a bag of un-namespaced topics (``/odom``, ``/scan``, ``/tf``) plays as the first
robot not yet bound. A robot's configured topics are looked up in its bag as written, then without the robot's
namespace (``/robot1/odom`` -> ``/odom``), so single-robot bags play with the default robots.yaml. The pose
topic must be in the bag with the expected type; the scan, sensors and cameras it lacks are left out. Robots
bound to no bag stay offline, and no robot can be commanded (:meth:`BagBackend.command_refusal`).

**Timing.** All bags start together at position 0 (each at its own first message) and keep their recorded
timing scaled by the rate, on the event loop's clock (:class:`PlaybackClock`). Pause, resume, seek and rate
come from clients (``playback/...``); a ``PlaybackEvent`` reports the position once a second and on every
change. At the end, playback starts over with ``--loop`` and otherwise stays paused at the end. Stamps are
the messages' own (header stamps, else the time they were recorded), as a live robot would have sent them.

**Threads.** Each bag has one reader thread (:class:`_BagReader`) that owns its rosbags reader: it decodes the
messages its robots need, in time order, turns them into immutable events (poses, composed from TF when the
pose source is ``tf``; decimated scans; sensor values; maps) and appends them to a bounded buffer ahead of
the playback position; a bag is never read into memory whole. On the loop, one task per bag pops events from
that buffer when the clock reaches them (the lock is held for microseconds) and hands them to the relay.
Camera images cross the same buffer as decoded messages and are converted to JPEG (relay.imaging) in a small
worker pool, only when a client streams or snapshots that camera.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import contextlib
import functools
import logging
import math
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..config import Camera, FleetConfig, Robot, Sensor
from ..errors import BackendUnavailable, CommandRejected
from ..events import (
    Event,
    EventSink,
    FrameEvent,
    MapEvent,
    PlaybackEvent,
    PoseEvent,
    RobotModelEvent,
    ScanEvent,
    SensorEvent,
)
from ..imaging import ImageError, compressed_to_jpeg, encode_jpeg, raw_to_bgr
from ..maps import map_event
from ..options import BagOptions
from ..protocol import MAX_PLAYBACK_RATE, MAX_SCAN_RATE, MIN_PLAYBACK_RATE, ROBOT_NAME_PATTERN, ErrorCode
from ..scan import scan_event
from ..tf import TfPose, Transform, compose, rotate, strip_slash
from .base import Backend
from .ros import POSE_MESSAGES, SENSOR_MESSAGES

logger = logging.getLogger(__name__)

#: After a seek, the reader starts this much earlier (s) to know the state at the target: the latest pose,
#: scan, sensor values and image, and TF's map->odom (AMCL publishes it at ~10 Hz, with gaps of ~3 s).
PREROLL = 3.0
#: The reader stays at most this many events, image bytes, or seconds of the recording ahead of playback, and
#: refills once half of that was played: decoding in chunks, at the pace of playback, never the whole bag.
MAX_BUFFERED_ITEMS = 5000
MAX_BUFFERED_BYTES = 64 * 1024 * 1024
MAX_BUFFERED_SECONDS = 10.0
#: How often the playback position is reported when nothing changes (s).
PLAYBACK_REPORT_PERIOD = 1.0
#: A snapshot waits this long for a camera's first image (s).
SNAPSHOT_TIMEOUT = 2.0
#: The loop task delivering a bag's events yields to other tasks after delivering for this long (s): a replay
#: catching up at rate 20 must not hold the loop (clients' frames, estop) for more than a few milliseconds.
DELIVERY_SLICE = 0.01
#: Type definitions for bags that store none (rosbag2 sqlite3 before Iron): ROS 2 Humble's.
DEFAULT_TYPESTORE = "ros2_humble"
#: TF messages seen without one transform of a robot's chain before the reader says which frames it saw.
TF_DIAGNOSIS_AFTER = 200


def message_type(module: str, cls: str) -> str:
    """``("nav_msgs.msg", "Odometry")`` -> ``"nav_msgs/msg/Odometry"``: the rosbag2 spelling of a type."""
    return f"{module.replace('.', '/')}/{cls}"


POSE_TYPES: dict[str, str] = {source: message_type(*spec) for source, spec in POSE_MESSAGES.items()}
SCAN_TYPE = "sensor_msgs/msg/LaserScan"
IMAGE_TYPE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE_TYPE = "sensor_msgs/msg/CompressedImage"
MAP_TYPE = "nav_msgs/msg/OccupancyGrid"

# --------------------------------------------------------------------------------------------------
# Binding bags to robots (pure: no I/O beyond a stat of the given paths)
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BagSpec:
    """One ``--bag`` argument: ``PATH`` or ``ROBOT=PATH``."""

    text: str  # as given on the command line
    path: Path
    robot: str | None

    @property
    def shown(self) -> str:
        """The path as the user wrote it, for messages."""
        return self.text.partition("=")[2] if self.robot is not None else self.text


def parse_bag_specs(specs: Sequence[str], config: FleetConfig) -> list[BagSpec]:
    """Parse ``--bag`` arguments; raise BackendUnavailable naming an unknown robot or a missing path.

    ``NAME=PATH`` binds when NAME looks like a robot name and the whole argument is not itself an existing
    path (a file may have ``=`` in its name).
    """
    if not specs:
        raise BackendUnavailable(
            "the 'bag' backend needs at least one --bag [ROBOT=]PATH: a rosbag2 directory, or an .mcap or .db3 file"
        )
    result: list[BagSpec] = []
    for text in specs:
        name, sep, rest = text.partition("=")
        robot: str | None = None
        path_text = text
        if sep and ROBOT_NAME_PATTERN.match(name) and not Path(text).exists():
            if config.robot(name) is None:
                raise BackendUnavailable(
                    f"--bag {text}: unknown robot {name!r}; {config.source} defines {', '.join(config.names)}"
                )
            robot, path_text = name, rest
        path = Path(path_text).expanduser()
        if not path.exists():
            raise BackendUnavailable(
                f"--bag {text}: {path_text}: no such bag (expected a rosbag2 directory, or an .mcap or .db3 file)"
            )
        if robot is not None and any(s.robot == robot for s in result):
            raise BackendUnavailable(f"--bag {text}: {robot} is already bound to another bag")
        result.append(BagSpec(text, path, robot))
    return result


@dataclass(frozen=True)
class BagContents:
    """What a bag holds, as its reader found it."""

    start_ns: int
    end_ns: int
    topics: Mapping[str, str]  # topic -> message type

    @property
    def duration(self) -> float:
        return (self.end_ns - self.start_ns) * 1e-9


@dataclass(frozen=True)
class RobotTopics:
    """The bag topics one robot plays from (bag spelling: possibly without the robot's namespace)."""

    robot: Robot
    pose: str
    tf_static: str | None = None  # with pose source tf
    scan: str | None = None
    sensors: tuple[tuple[Sensor, str], ...] = ()
    cameras: tuple[tuple[Camera, str], ...] = ()
    missing: tuple[str, ...] = ()  # what robots.yaml asks for that the bag lacks, for the log

    def describe(self) -> str:
        parts = [f"pose {self.pose}"]
        if self.scan:
            parts.append(f"scan {self.scan}")
        parts += [f"{s.name} {t}" for s, t in self.sensors]
        parts += [f"camera {c.name} {t}" for c, t in self.cameras]
        if self.missing:
            parts.append("not in the bag: " + ", ".join(self.missing))
        return "; ".join(parts)


@dataclass(frozen=True)
class BagPlan:
    """What to read from one bag: its robots' topics, and the fleet's map when this bag carries it."""

    robots: tuple[RobotTopics, ...]
    map_topic: str | None = None


def _lookup(topic: str, robot: Robot, topics: Mapping[str, str], strip: bool) -> str | None:
    """``topic`` as the bag spells it: as written, else (``strip``) without the robot's namespace."""
    if topic in topics:
        return topic
    namespace = robot.namespace
    if strip and namespace and topic.startswith(namespace + "/"):
        bare = topic[len(namespace) :]
        if bare in topics:
            return bare
    return None


def _check_type(spec: BagSpec, topic: str, found: str, expected: str, what: str) -> None:
    if found != expected:
        raise BackendUnavailable(f"{spec.shown}: {topic} is {found}, but {what} needs {expected}")


def _topic_list(topics: Iterable[str], limit: int = 16) -> str:
    names = sorted(topics)
    shown = ", ".join(names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "") if names else "none"


def _robot_topics(config: FleetConfig, robot: Robot, spec: BagSpec, contents: BagContents, strip: bool) -> RobotTopics:
    topics = contents.topics
    source = robot.pose.source
    pose = _lookup(robot.pose.topic, robot, topics, strip)
    if pose is None:
        wanted = robot.pose.topic
        if strip and robot.namespace and wanted.startswith(robot.namespace + "/"):
            wanted += f" (or {wanted[len(robot.namespace) :]})"
        tf = _lookup(f"{robot.namespace}/tf", robot, topics, strip=True)
        if source != "tf" and tf is not None and topics[tf] == POSE_TYPES["tf"]:
            raise BackendUnavailable(
                f"{spec.shown}: {robot.name} takes its pose from {source} on {wanted}, which this bag does not "
                f"have; the bag has TF on {tf}: set `pose: {{source: tf, base_frame: <the robot's base frame>}}` "
                f"for {robot.name} in {config.source}"
            )
        raise BackendUnavailable(
            f"{spec.shown}: {robot.name} takes its pose from {source} on {wanted}, which this bag does not have "
            f"(its topics: {_topic_list(topics)}); set {robot.name}'s `pose` in {config.source} to a topic it has"
        )
    _check_type(spec, pose, topics[pose], POSE_TYPES[source], f"{robot.name}'s pose source {source}")
    tf_static = None
    if source == "tf":
        tf_static = _lookup(robot.pose.topic + "_static", robot, topics, strip)
        if tf_static is not None:
            _check_type(spec, tf_static, topics[tf_static], POSE_TYPES["tf"], f"{robot.name}'s static TF")
    missing: list[str] = []
    scan = None
    if robot.scan_topic is not None:
        scan = _lookup(robot.scan_topic, robot, topics, strip)
        if scan is None:
            missing.append(f"scan {robot.scan_topic}")
        else:
            _check_type(spec, scan, topics[scan], SCAN_TYPE, f"{robot.name}'s scan")
    sensors: list[tuple[Sensor, str]] = []
    for sensor in robot.sensors:
        topic = _lookup(sensor.topic, robot, topics, strip)
        if topic is None:
            missing.append(f"{sensor.name} {sensor.topic}")
            continue
        _check_type(spec, topic, topics[topic], sensor.type, f"{robot.name}'s sensor {sensor.name}")
        sensors.append((sensor, topic))
    cameras: list[tuple[Camera, str]] = []
    for camera in robot.cameras:
        topic = _lookup(camera.topic, robot, topics, strip)
        if topic is None:
            missing.append(f"camera {camera.name} {camera.topic}")
            continue
        expected = COMPRESSED_IMAGE_TYPE if camera.compressed else IMAGE_TYPE
        _check_type(spec, topic, topics[topic], expected, f"{robot.name}'s camera {camera.name}")
        cameras.append((camera, topic))
    return RobotTopics(robot, pose, tf_static, scan, tuple(sensors), tuple(cameras), tuple(missing))


def bind_bags(config: FleetConfig, specs: Sequence[BagSpec], contents: Sequence[BagContents]) -> list[BagPlan]:
    """Which robots each bag plays as, and from which of its topics (see the module docstring).

    Raises BackendUnavailable naming the bag when a robot's pose is not in it, a topic has the wrong type,
    or an unbound bag has no robot left to play as.
    """
    bound: set[str] = {s.robot for s in specs if s.robot is not None}
    robots: list[list[RobotTopics]] = [[] for _ in specs]
    for index, spec in enumerate(specs):
        if spec.robot is not None:
            robot = config.robot(spec.robot)
            assert robot is not None  # parse_bag_specs checked it
            robots[index].append(_robot_topics(config, robot, spec, contents[index], strip=True))
    for index, spec in enumerate(specs):
        if spec.robot is not None:
            continue
        topics = contents[index].topics
        # A recording of the fleet carries the robots' own namespaced topics.
        namespaced = [r for r in config.robots if r.namespace and r.pose.topic in topics]
        if namespaced:
            fresh = [r for r in namespaced if r.name not in bound]
            for robot in namespaced:
                if robot.name in bound:
                    logger.warning(
                        "%s: %s is already bound to another bag; its topics here are ignored", spec.shown, robot.name
                    )
            if not fresh:
                raise BackendUnavailable(
                    f"{spec.shown}: every robot it holds ({', '.join(r.name for r in namespaced)}) is already bound "
                    "to another bag"
                )
            for robot in fresh:
                robots[index].append(_robot_topics(config, robot, spec, contents[index], strip=False))
                bound.add(robot.name)
            continue
        free = next((r for r in config.robots if r.name not in bound), None)
        if free is None:
            raise BackendUnavailable(
                f"{spec.shown}: no robot left to play it as: every robot of {config.source} is bound to another "
                "bag; add a robot to the config, or bind the bags with ROBOT=PATH"
            )
        robots[index].append(_robot_topics(config, free, spec, contents[index], strip=True))
        bound.add(free.name)
    plans: list[BagPlan] = []
    map_taken = False
    for index, content in enumerate(contents):
        map_topic = None
        if content.topics.get(config.ros.map_topic) == MAP_TYPE and not map_taken:
            # The map is fleet-wide: the first bag that has it provides it.
            map_topic, map_taken = config.ros.map_topic, True
        plans.append(BagPlan(tuple(robots[index]), map_topic))
    return plans


# --------------------------------------------------------------------------------------------------
# TF: a robot's map-frame pose through the static tree (relay.tf.TfPose does map->odom->base)
# --------------------------------------------------------------------------------------------------

IDENTITY = Transform((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))


def inverse(transform: Transform) -> Transform:
    x, y, z, w = transform.rotation
    conjugate = (-x, -y, -z, w)
    tx, ty, tz = rotate(conjugate, transform.translation)
    return Transform((-tx, -ty, -tz), conjugate)


class _TfChain:
    """One robot's pose from TF: map->odom composed with odom->X and X's static path to the base frame.

    The recording's base frame need not be the configured one: a TurtleBot3 publishes odom->base_footprint,
    a TurtleBot4 odom->base_link, and /tf_static links the two either way. Reader thread only.
    """

    def __init__(self, robot: Robot) -> None:
        self.robot = robot.name
        spec = robot.pose
        self.map_frame = strip_slash(spec.map_frame)
        self.odom_frame = strip_slash(spec.odom_frame)
        self.base_frame = strip_slash(spec.base_frame)
        self._statics: dict[str, tuple[str, Transform]] = {}  # child -> (parent, child's pose in parent)
        self._links: dict[str, Transform | None] = {}  # frame -> base's pose in it, through the statics
        self._seen: set[tuple[str, str]] = set()
        self._idle = 0
        self._diagnosed = False
        self.reset()

    def reset(self) -> None:
        """Forget the moving transforms (a seek); the static ones stay."""
        self._tracker = TfPose(self.map_frame, self.odom_frame, self.base_frame)
        self._stamp: float | None = None

    def add_static(self, message: Any) -> None:
        for t in message.transforms:
            parent, child = strip_slash(t.header.frame_id), strip_slash(t.child_frame_id)
            self._statics[child] = (parent, _transform(t))
        self._links.clear()

    def _ancestors(self, frame: str) -> dict[str, Transform]:
        """``frame``'s pose in itself and in each of its static ancestors, nearest first."""
        result = {frame: IDENTITY}
        pose, current = IDENTITY, frame
        while current in self._statics:
            parent, transform = self._statics[current]
            if parent in result:  # a cycle in a broken recording
                break
            pose = compose(transform, pose)
            result[parent] = pose
            current = parent
        return result

    def _link(self, frame: str) -> Transform | None:
        """The base frame's pose in ``frame`` through the static tree, or None when they are not linked."""
        if frame not in self._links:
            link = None
            of_frame = self._ancestors(frame)
            for ancestor, base_in_ancestor in self._ancestors(self.base_frame).items():
                if ancestor in of_frame:
                    link = compose(inverse(of_frame[ancestor]), base_in_ancestor)
                    break
            self._links[frame] = link
        return self._links[frame]

    def feed(self, message: Any, log_time: float) -> PoseEvent | None:
        """One TFMessage; the robot's pose when it changed the chain."""
        changed = False
        for t in message.transforms:
            parent, child = strip_slash(t.header.frame_id), strip_slash(t.child_frame_id)
            if parent == self.map_frame and child == self.odom_frame:
                changed = self._tracker.feed(parent, child, _transform(t)) or changed
            elif parent == self.odom_frame:
                link = self._link(child)
                if link is None:
                    self._seen.add((parent, child))
                    continue
                self._tracker.feed(parent, self.base_frame, compose(_transform(t), link))
                # The pose is as old as the robot's motion: AMCL stamps map->odom into the future.
                self._stamp = _stamp_of(t.header, log_time)
                changed = True
            else:
                self._seen.add((parent, child))
        result = self._tracker.pose() if changed else None
        if result is None:
            self._diagnose()
            return None
        self._idle = 0
        frame, pose = result
        (x, y, z), (qx, qy, qz, qw) = pose.translation, pose.rotation
        stamp = self._stamp if self._stamp is not None else log_time
        return PoseEvent(self.robot, stamp, frame, x, y, z, qx, qy, qz, qw)

    def _diagnose(self) -> None:
        self._idle += 1
        if self._idle >= TF_DIAGNOSIS_AFTER and not self._diagnosed:
            self._diagnosed = True
            seen = ", ".join(f"{p}->{c}" for p, c in sorted(self._seen)[:12]) or "none"
            logger.warning(
                "%s: TF has no %s->%s (directly or through /tf_static) after %d messages; transforms seen: %s. "
                "Set pose.odom_frame and pose.base_frame in robots.yaml to the recording's frames",
                self.robot,
                self.odom_frame,
                self.base_frame,
                self._idle,
                seen,
            )


def _transform(t: Any) -> Transform:
    tr, q = t.transform.translation, t.transform.rotation
    return Transform((float(tr.x), float(tr.y), float(tr.z)), (float(q.x), float(q.y), float(q.z), float(q.w)))


def _stamp_of(header: Any, fallback: float) -> float:
    """A header's stamp in seconds; a zero stamp (publisher left it unset) gets the recording time."""
    value = float(header.stamp.sec) + float(header.stamp.nanosec) * 1e-9
    return value if value > 0 else fallback


def _stamp(message: Any, fallback: float) -> float:
    header = getattr(message, "header", None)
    return _stamp_of(header, fallback) if header is not None else fallback


# --------------------------------------------------------------------------------------------------
# The reader thread: messages -> events, into a bounded buffer
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class _Image:
    """A decoded camera image waiting for a JPEG encode (only if someone looks)."""

    robot: str
    camera: str
    compressed: bool
    stamp: float
    message: Any  # a rosbags sensor_msgs Image or CompressedImage; never mutated


Payload = Event | _Image
Key = tuple[str, ...]
Handler = Callable[[Any, float], "Payload | None"]


@dataclass(frozen=True, slots=True)
class _Item:
    position: float  # seconds from the bag's first message
    payload: Payload | None  # None marks the end of the bag
    size: int = 0  # bytes of image data it holds


def _pose_handler(robot: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        # Odometry and PoseWithCovarianceStamped nest the pose once more than PoseStamped.
        pose = message.pose.pose if hasattr(message.pose, "pose") else message.pose
        p, q = pose.position, pose.orientation
        frame = message.header.frame_id or "map"
        return PoseEvent(
            robot, _stamp(message, log_time), frame, float(p.x), float(p.y), float(p.z), q.x, q.y, q.z, q.w
        )

    return handle


def _sensor_handler(robot: str, sensor: Sensor) -> Handler:
    extract = SENSOR_MESSAGES[sensor.type][2]

    def handle(message: Any, log_time: float) -> Payload:
        return SensorEvent(robot, sensor.name, extract(message), _stamp(message, log_time))

    return handle


def _scan_handler(robot: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return scan_event(robot, _stamp(message, log_time), message)

    return handle


def _camera_handler(robot: str, camera: Camera) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return _Image(robot, camera.name, camera.compressed, _stamp(message, log_time), message)

    return handle


def _map_handler(topic: str) -> Handler:
    def handle(message: Any, log_time: float) -> Payload:
        return map_event(message, _stamp(message, log_time), topic)

    return handle


class _Decoder:
    """Reader thread: routes each message of a plan's topics to the handlers that turn it into payloads."""

    def __init__(self, plan: BagPlan, name: str) -> None:
        self.name = name
        self.routes: dict[str, list[tuple[Key, Handler]]] = collections.defaultdict(list)
        self.statics: dict[str, list[_TfChain]] = collections.defaultdict(list)
        self.chains: list[_TfChain] = []
        self._warned: set[str] = set()
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
        if plan.map_topic is not None:
            self.routes[plan.map_topic].append((("map",), _map_handler(plan.map_topic)))

    def reset(self) -> None:
        for chain in self.chains:
            chain.reset()

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
        return out


def _size(payload: Payload) -> int:
    if isinstance(payload, _Image):
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


class _BagReader:
    """One bag: its reader thread and the bounded buffer of events it fills ahead of playback.

    ``_cond`` guards ``_buffer``, ``_bytes``, ``_generation``, ``_start``, ``_plan`` and ``_stopped``. The thread
    owns the rosbags reader and the decoder. The loop calls :meth:`play`, :meth:`restart`, :meth:`peek`,
    :meth:`pop` and :meth:`close`, which hold the lock only for a few operations and never wait. Every seek
    starts a new generation: the buffer is emptied and the thread abandons its pass and reads from the target.
    """

    def __init__(self, spec: BagSpec, loop: asyncio.AbstractEventLoop) -> None:
        self.spec = spec
        self.opened: concurrent.futures.Future[BagContents] = concurrent.futures.Future()
        #: Set on the loop when the buffer gains an item after being empty, and on every playback change.
        self.ready = asyncio.Event()
        self.contents: BagContents | None = None
        self._loop = loop
        self._cond = threading.Condition()
        self._buffer: collections.deque[_Item] = collections.deque()
        self._bytes = 0
        self._generation = 0
        self._start = 0.0
        self._plan: BagPlan | None = None
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name=f"bag-{spec.path.name}", daemon=True)

    # -- loop side --------------------------------------------------------------------------------

    def start_thread(self) -> None:
        self._thread.start()

    def play(self, plan: BagPlan, start: float) -> None:
        with self._cond:
            self._plan = plan
            self._start = start
            self._generation += 1
            self._cond.notify_all()

    def restart(self, start: float) -> None:
        """Drop what was read ahead and read again from ``start`` (s from the bag's first message)."""
        with self._cond:
            self._generation += 1
            self._start = start
            self._buffer.clear()
            self._bytes = 0
            self._cond.notify_all()
        self.ready.set()

    def peek(self) -> _Item | None:
        with self._cond:
            return self._buffer[0] if self._buffer else None

    def pop(self) -> None:
        with self._cond:
            if self._buffer:
                self._bytes -= self._buffer.popleft().size
            if self._room(0.5):
                self._cond.notify_all()

    def close(self) -> None:
        with self._cond:
            self._stopped = True
            self._cond.notify_all()

    def join(self, timeout: float) -> None:
        if self._thread.is_alive():
            self._thread.join(timeout)

    # -- reader thread ----------------------------------------------------------------------------

    def _wake(self) -> None:
        # The loop may be closed already at shutdown: then nobody waits.
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self.ready.set)

    def _current(self, generation: int) -> bool:
        return self._generation == generation and not self._stopped

    def _room(self, fraction: float) -> bool:
        """Whether the buffer is below ``fraction`` of its limits (call with ``_cond`` held)."""
        if not self._buffer:
            return True
        ahead = self._buffer[-1].position - self._buffer[0].position
        return (
            len(self._buffer) < MAX_BUFFERED_ITEMS * fraction
            and self._bytes < MAX_BUFFERED_BYTES * fraction
            and ahead < MAX_BUFFERED_SECONDS * fraction
        )

    def _push(self, generation: int, item: _Item) -> bool:
        """Append ``item`` once there is room; False when a seek or stop made this pass obsolete."""
        with self._cond:
            while self._current(generation) and not self._room(1.0):
                self._cond.wait()
            if not self._current(generation):
                return False
            was_empty = not self._buffer
            self._buffer.append(item)
            self._bytes += item.size
        if was_empty:
            self._wake()
        return True

    def _run(self) -> None:
        try:
            reader, deserializers = self._open()
        except Exception as exc:
            reason = " ".join(str(exc).split()) or type(exc).__name__
            self.opened.set_exception(BackendUnavailable(f"{self.spec.shown}: cannot read this bag: {reason}"))
            return
        try:
            assert self.contents is not None
            self.opened.set_result(self.contents)
            with self._cond:
                while self._plan is None and not self._stopped:
                    self._cond.wait()
                plan = self._plan
            if plan is not None:
                self._serve(reader, deserializers, plan)
        except Exception as exc:
            if not self.opened.done():  # start() waits on it: it must always be resolved
                self.opened.set_exception(BackendUnavailable(f"{self.spec.shown}: cannot read this bag: {exc}"))
            logger.exception("%s: the bag reader failed; this recording stops here", self.spec.shown)
        finally:
            with contextlib.suppress(Exception):
                reader.close()

    def _open(self) -> tuple[Any, dict[str, Callable[[bytes], Any]]]:
        # rosbags takes ~0.2 s to import and ~0.4 s to open a bag: both happen here, never on the loop.
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        default = get_typestore(Stores(DEFAULT_TYPESTORE))
        # Definitions stored in the bag (MCAP, rosbag2 >= Iron) win; older bags get Humble's.
        reader = AnyReader([self.spec.path], default_typestore=default)
        reader.open()
        try:
            if reader.message_count == 0:
                raise ValueError("it contains no messages")
            # Reading the first message finds a corrupt start now, rather than as an empty replay later.
            with contextlib.closing(reader.messages()) as messages:
                next(messages, None)
            topics: dict[str, str] = {}
            deserializers: dict[str, Callable[[bytes], Any]] = {}
            for connection in reader.connections:
                topic, msgtype = connection.topic, connection.msgtype
                if topics.setdefault(topic, msgtype) != msgtype:
                    logger.warning(
                        "%s: %s is recorded as two types; only %s is read", self.spec.shown, topic, topics[topic]
                    )
                if msgtype in deserializers:
                    continue
                if msgtype in reader.typestore.fielddefs:
                    deserializers[msgtype] = functools.partial(reader.deserialize, typ=msgtype)
                elif msgtype in default.fielddefs:
                    # The bag defines some types but not this one: ROS 2 Humble's definition stands in.
                    deserializers[msgtype] = functools.partial(default.deserialize_cdr, typename=msgtype)
                else:
                    logger.warning(
                        "%s: %s is %s, which neither the bag nor the ROS 2 Humble type store defines; skipped",
                        self.spec.shown,
                        topic,
                        msgtype,
                    )
            self.contents = BagContents(int(reader.start_time), int(reader.end_time), topics)
            return reader, deserializers
        except BaseException:
            with contextlib.suppress(Exception):
                reader.close()
            raise

    def _serve(self, reader: Any, deserializers: dict[str, Callable[[bytes], Any]], plan: BagPlan) -> None:
        decoder = _Decoder(plan, self.spec.shown)
        decodable = [c for c in reader.connections if c.msgtype in deserializers]
        # Static transforms hold for the whole recording, wherever they were recorded: read them first.
        statics = [c for c in decodable if c.topic in decoder.statics]
        if statics:
            for connection, _, raw in reader.messages(connections=statics):
                message = deserializers[connection.msgtype](raw)
                for chain in decoder.statics[connection.topic]:
                    chain.add_static(message)
        connections = [c for c in decodable if c.topic in decoder.routes]
        done = 0
        while True:
            with self._cond:
                while not self._stopped and self._generation == done:
                    self._cond.wait()
                if self._stopped:
                    return
                generation, start = self._generation, self._start
            self._pass(reader, deserializers, decoder, connections, generation, start)
            done = generation

    def _pass(
        self,
        reader: Any,
        deserializers: dict[str, Callable[[bytes], Any]],
        decoder: _Decoder,
        connections: list[Any],
        generation: int,
        start: float,
    ) -> None:
        """Read from ``start`` to the end (or until a seek), then mark the end."""
        contents = self.contents
        assert contents is not None
        decoder.reset()
        target = contents.start_ns + round(start * 1e9)
        first = max(contents.start_ns, target - round(PREROLL * 1e9))
        latest: dict[Key, Payload] = {}  # the state at the target, from the preroll

        def flush() -> bool:
            items = [_Item(start, payload, _size(payload)) for payload in latest.values()]
            latest.clear()
            return all(self._push(generation, item) for item in items)

        try:
            with contextlib.closing(reader.messages(connections=connections, start=first)) as messages:
                for connection, log_ns, raw in messages:
                    if not self._current(generation):  # a seek or stop: abandon this pass
                        return
                    if latest and log_ns >= target and not flush():
                        return
                    try:
                        message = deserializers[connection.msgtype](raw)
                    except Exception as exc:
                        decoder.warn_once(connection.topic, "cannot decode a message of", exc)
                        continue
                    for key, payload in decoder.decode(connection.topic, message, log_ns * 1e-9):
                        if log_ns < target:
                            latest[key] = payload
                        elif not self._push(
                            generation, _Item((log_ns - contents.start_ns) * 1e-9, payload, _size(payload))
                        ):
                            return
        except Exception as exc:  # a corrupt chunk further in: play what could be read
            logger.error("%s: cannot read further: %s; the recording ends here", self.spec.shown, exc)
        if flush():
            self._push(generation, _Item(contents.duration, None))


# --------------------------------------------------------------------------------------------------
# The playback clock and the backend (event loop)
# --------------------------------------------------------------------------------------------------


class PlaybackClock:
    """Where playback is, in seconds from the recordings' start, as a function of a monotonic clock.

    Contract: ``0 <= position() <= duration``. While playing, the position advances ``rate`` seconds per
    second of ``now()``; pause, resume, seek and rate changes re-anchor it, so it only jumps at seeks.
    """

    def __init__(self, now: Callable[[], float], duration: float, rate: float, start: float) -> None:
        self._now = now
        self.duration = max(0.0, duration)
        self.rate = rate
        self.paused = False
        self._anchor_position = min(max(0.0, start), self.duration)
        self._anchor_time = now()

    def position(self) -> float:
        if self.paused:
            return self._anchor_position
        elapsed = (self._now() - self._anchor_time) * self.rate
        return min(self.duration, self._anchor_position + elapsed)

    def _anchor(self, position: float) -> None:
        self._anchor_position = min(max(0.0, position), self.duration)
        self._anchor_time = self._now()

    def pause(self) -> None:
        self._anchor(self.position())
        self.paused = True

    def resume(self) -> None:
        self._anchor(self.position())
        self.paused = False

    def seek(self, position: float) -> None:
        self._anchor(position)

    def set_rate(self, rate: float) -> None:
        self._anchor(self.position())
        self.rate = rate

    def wall_delay(self, position: float) -> float | None:
        """Seconds of ``now()`` until the clock reaches ``position``: 0 once it has, None while paused."""
        current = self.position()
        if position <= current:
            return 0.0
        if self.paused:
            return None
        return (position - current) / self.rate


@dataclass
class _CameraState:
    """One camera's images on the loop: the newest decoded one, and its JPEG once someone asked."""

    latest: _Image | None = None
    fps: float = 0.0
    last_accepted: float = -math.inf  # loop time of the last image sent to encoding
    encoding: bool = False
    pending: bool = False  # a newer image arrived while encoding
    frame: FrameEvent | None = None
    frame_of: _Image | None = None  # the image ``frame`` was made from
    waiters: list[asyncio.Future[FrameEvent | None]] = field(default_factory=list)


def _to_frame(image: _Image) -> FrameEvent:
    """Worker thread: one image to JPEG, the same way as live cameras (relay.imaging)."""
    message = image.message
    if image.compressed:
        jpeg, width, height = compressed_to_jpeg(bytes(message.data), message.format)
    else:
        bgr = raw_to_bgr(
            message.data,
            int(message.width),
            int(message.height),
            message.encoding,
            int(message.step),
            bool(message.is_bigendian),
        )
        jpeg, width, height = encode_jpeg(bgr), int(message.width), int(message.height)
    return FrameEvent(image.robot, image.camera, image.stamp, width, height, jpeg)


async def _wait(event: asyncio.Event, delay: float | None) -> None:
    """Until ``event`` is set or ``delay`` seconds passed (a timer, not a task: this runs per event)."""
    if delay is None:
        await event.wait()
        return
    if delay <= 0:
        await asyncio.sleep(0)  # still a suspension point: callers loop on this
        return
    handle = asyncio.get_running_loop().call_later(delay, event.set)
    try:
        await event.wait()
    finally:
        handle.cancel()


class BagBackend(Backend):
    """Replays recordings as the robots of robots.yaml. Everything here runs on the event loop."""

    name = "bag"

    def __init__(self, config: FleetConfig, sink: EventSink, options: BagOptions) -> None:
        """Check the arguments (cheap: a stat per path); opening the bags happens in :meth:`start`."""
        super().__init__(config, sink)
        if not (math.isfinite(options.rate) and MIN_PLAYBACK_RATE <= options.rate <= MAX_PLAYBACK_RATE):
            raise BackendUnavailable(
                f"--rate {options.rate:g}: expected a speed factor from {MIN_PLAYBACK_RATE:g} to {MAX_PLAYBACK_RATE:g}"
            )
        if not (math.isfinite(options.start) and options.start >= 0):
            raise BackendUnavailable(f"--start {options.start:g}: expected seconds from the recordings' start, >= 0")
        self.options = options
        self._specs = parse_bag_specs(options.bags, config)
        self._readers: list[_BagReader] = []
        self._plans: list[BagPlan] = []
        self._bound: dict[str, BagSpec] = {}
        self._clock: PlaybackClock | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._ticker_wake = asyncio.Event()
        self._last_pose: dict[str, PoseEvent] = {}
        self._last_scan: dict[str, float] = {}
        self._cameras: dict[tuple[str, str], _CameraState] = {}
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=2, thread_name_prefix="bag-jpeg")

    # -- lifecycle --------------------------------------------------------------------------------

    async def _send_models(self, plans: Sequence[BagPlan], contents: Sequence[BagContents]) -> None:
        """Robots whose model comes from robot_description get the URDF recorded in their bag, whatever the
        start position (it is published once, at the beginning)."""
        for spec, plan, content in zip(self._specs, plans, contents, strict=True):
            for topics in plan.robots:
                source = topics.robot.model_source
                if source is None:
                    continue
                topic = _lookup(source.topic, topics.robot, content.topics, strip=True)
                if topic is None or content.topics[topic] != "std_msgs/msg/String":
                    logger.warning("%s: no robot_description (%s) for %s", spec.shown, source.topic, topics.robot.name)
                    continue
                urdf = await asyncio.to_thread(_first_string, spec.path, topic)
                if urdf:
                    self.sink(RobotModelEvent(topics.robot.name, urdf))

    async def start(self) -> None:
        """Open every bag (reader threads), bind them to robots and start playing.

        Raises BackendUnavailable naming the file when a bag is missing, corrupt or truncated, or does not
        fit robots.yaml; nothing keeps running then.
        """
        loop = asyncio.get_running_loop()
        readers = [_BagReader(spec, loop) for spec in self._specs]
        for reader in readers:
            reader.start_thread()
        try:
            contents = [await asyncio.wrap_future(reader.opened) for reader in readers]
            plans = bind_bags(self.config, self._specs, contents)
        except BaseException:
            await self._close(readers)
            raise
        self._readers, self._plans = readers, plans
        duration = max(c.duration for c in contents)
        start = min(self.options.start, duration)
        if start < self.options.start:
            logger.warning(
                "--start %.1f is past the end of the recordings (%.1f s): starting at the end",
                self.options.start,
                duration,
            )
        self._clock = PlaybackClock(loop.time, duration, self.options.rate, start)
        for spec, plan in zip(self._specs, plans, strict=True):
            for topics in plan.robots:
                self._bound[topics.robot.name] = spec
                for camera, _ in topics.cameras:
                    self._cameras[(topics.robot.name, camera.name)] = _CameraState()
                logger.info("%s plays %s: %s", topics.robot.name, spec.shown, topics.describe())
            if plan.map_topic is not None:
                logger.info("the map comes from %s of %s", plan.map_topic, spec.shown)
        offline = [r for r in self.config.names if r not in self._bound]
        if offline:
            logger.info("not in any recording, offline: %s", ", ".join(offline))
        await self._send_models(plans, contents)
        for reader, plan in zip(readers, plans, strict=True):
            reader.play(plan, start)
            self._tasks.append(loop.create_task(self._play(reader), name=f"bag-play-{reader.spec.path.name}"))
        self._tasks.append(loop.create_task(self._tick(), name="bag-playback"))
        self._emit_playback()  # before any client connects: the first hello already says where playback is
        logger.info(
            "replaying %d bag(s): %.1f s from %.1f s at rate %g%s",
            len(readers),
            duration,
            start,
            self.options.rate,
            ", looping" if self.options.loop else "",
        )

    async def stop(self) -> None:
        tasks, self._tasks = self._tasks, []
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        readers, self._readers = self._readers, []
        await self._close(readers)
        self._pool.shutdown(wait=False, cancel_futures=True)

    @staticmethod
    async def _close(readers: Sequence[_BagReader]) -> None:
        for reader in readers:
            reader.close()

        def join() -> None:
            for reader in readers:
                reader.join(2.0)

        await asyncio.to_thread(join)

    # -- commands: a recording cannot be commanded ------------------------------------------------

    def command_refusal(self, robot: str) -> str | None:
        spec = self._bound.get(robot)
        if spec is not None:
            return f"{robot} is a recording (bag {spec.shown}); it cannot be commanded"
        return f"{robot} is not in any of the replayed recordings; with --backend bag no robot can be commanded"

    async def send_velocity(self, robot: str, linear: float, angular: float) -> None:
        """Nothing to drive: only stop paths (deadman, estop, shutdown) get here, and a recording is stopped."""

    async def send_goal(self, robot: str, x: float, y: float, yaw: float | None) -> None:
        """Never reached for goals (command_refusal refuses them all); a no-op."""

    async def cancel(self, robot: str) -> None:
        """Only stop paths get here; a recording has no goal to cancel."""

    # -- playback ---------------------------------------------------------------------------------

    def _require_clock(self) -> PlaybackClock:
        if self._clock is None:
            raise CommandRejected(ErrorCode.INTERNAL, "the recordings are not open yet")
        return self._clock

    async def playback(self, action: str, value: float | None) -> None:
        """Pause, resume, seek (``value`` s from the start, clamped) or set the rate (``value``)."""
        clock = self._require_clock()
        if action == "pause":
            clock.pause()
        elif action == "resume":
            if clock.position() >= clock.duration:
                self._restart(0.0)  # play again from the start, as players do
            clock.resume()
        elif action == "seek" and value is not None:
            self._restart(min(max(0.0, value), clock.duration))
        elif action == "rate" and value is not None:
            clock.set_rate(value)
        else:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"playback/{action}: not a playback command")
        logger.info("playback %s%s", action, f" {value:g}" if value is not None else "")
        self._changed()

    def _restart(self, position: float) -> None:
        clock = self._require_clock()
        clock.seek(position)
        self._last_scan.clear()
        self._last_pose.clear()  # the paused re-report must not resend a pose from before the seek
        for state in self._cameras.values():
            state.latest = None  # an image from another time must not answer a snapshot
        for reader in self._readers:
            reader.restart(position)

    def _changed(self) -> None:
        """The clock changed: re-plan every delivery, and report the new state now."""
        for reader in self._readers:
            reader.ready.set()
        self._emit_playback()
        self._ticker_wake.set()

    def _emit_playback(self) -> None:
        clock = self._clock
        if clock is not None:
            self.sink(PlaybackEvent(clock.position(), clock.duration, clock.rate, clock.paused, self.options.loop))

    def health(self) -> dict[str, object]:
        clock = self._clock
        if clock is None:
            return {}
        return {
            "playback": {
                "position": round(clock.position(), 3),
                "duration": round(clock.duration, 3),
                "rate": clock.rate,
                "paused": clock.paused,
                "loop": self.options.loop,
            },
            "bags": [
                {"path": spec.shown, "robots": [t.robot.name for t in plan.robots]}
                for spec, plan in zip(self._specs, self._plans, strict=True)
            ],
        }

    async def _play(self, reader: _BagReader) -> None:
        """Deliver one bag's events when the clock reaches them (one task per bag)."""
        clock = self._require_clock()
        loop = asyncio.get_running_loop()
        slice_end = loop.time() + DELIVERY_SLICE
        while True:
            reader.ready.clear()
            item = reader.peek()
            if item is None or item.payload is None:  # nothing read yet, or the end of this bag
                await reader.ready.wait()
                slice_end = loop.time() + DELIVERY_SLICE
                continue
            delay = clock.wall_delay(item.position)
            if delay is None or delay > 0:
                await _wait(reader.ready, delay)
                slice_end = loop.time() + DELIVERY_SLICE
                continue
            # No await between peek and here: a seek (also on the loop) cannot slip in between.
            reader.pop()
            self._deliver(item.payload)
            if loop.time() >= slice_end:
                await asyncio.sleep(0)
                slice_end = loop.time() + DELIVERY_SLICE

    def _deliver(self, payload: Payload) -> None:
        if isinstance(payload, _Image):
            self._on_image(payload)
            return
        if isinstance(payload, PoseEvent):
            self._last_pose[payload.robot] = payload
        elif isinstance(payload, ScanEvent):
            # At most MAX_SCAN_RATE scans a second of wall time, whatever the replay rate.
            now = asyncio.get_running_loop().time()
            if now - self._last_scan.get(payload.robot, -math.inf) < 1.0 / MAX_SCAN_RATE:
                return
            self._last_scan[payload.robot] = now
        self.sink(payload)

    async def _tick(self) -> None:
        """Report the position once a second; at the end, loop or stay paused; keep paused robots online."""
        loop = asyncio.get_running_loop()
        clock = self._require_clock()
        next_report = loop.time()
        while True:
            self._ticker_wake.clear()
            if not clock.paused and clock.position() >= clock.duration:
                if self.options.loop and clock.duration > 1e-3:
                    logger.info("end of the recordings: starting over")
                    self._restart(0.0)
                else:
                    logger.info("end of the recordings: paused at %.1f s", clock.duration)
                    clock.pause()
                self._changed()
                continue
            now = loop.time()
            if now >= next_report:
                next_report = now + PLAYBACK_REPORT_PERIOD
                self._emit_playback()
                if clock.paused:
                    # A paused recording still shows its robots where they are, so they stay online.
                    for pose in self._last_pose.values():
                        self.sink(pose)
            timeout = next_report - now
            if not clock.paused:
                timeout = min(timeout, (clock.duration - clock.position()) / clock.rate)
            await _wait(self._ticker_wake, timeout)

    # -- cameras ----------------------------------------------------------------------------------

    def _on_image(self, image: _Image) -> None:
        state = self._cameras.get((image.robot, image.camera))
        if state is None:
            return
        state.latest = image
        now = asyncio.get_running_loop().time()
        if state.waiters or (state.fps > 0 and now - state.last_accepted >= 0.9 / state.fps):
            self._encode(state)

    def _encode(self, state: _CameraState) -> None:
        """Encode the newest image in the worker pool; one encode per camera at a time, newest wins."""
        if state.encoding:
            state.pending = True
            return
        image = state.latest
        if image is None:
            return
        loop = asyncio.get_running_loop()
        state.encoding, state.pending, state.last_accepted = True, False, loop.time()
        future = loop.run_in_executor(self._pool, _to_frame, image)
        future.add_done_callback(lambda f: self._encoded(state, image, f))

    def _encoded(self, state: _CameraState, image: _Image, future: asyncio.Future[FrameEvent]) -> None:
        state.encoding = False
        if future.cancelled():
            return
        frame: FrameEvent | None = None
        try:
            frame = future.result()
        except (ImageError, ValueError) as exc:
            logger.warning("%s camera %s: %s", image.robot, image.camera, exc)
        if frame is not None:
            state.frame, state.frame_of = frame, image
            self.sink(frame)
        for waiter in state.waiters:
            if not waiter.done():
                waiter.set_result(frame)
        state.waiters.clear()
        if state.pending and state.latest is not image:
            self._encode(state)

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        state = self._cameras.get((robot, camera))
        if state is not None:
            state.fps = fps

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        """The JPEG of the camera's image at the playback position (also while paused), or None."""
        state = self._cameras.get((robot, camera))
        clock = self._clock
        if state is None or clock is None:
            return None
        if state.frame is not None and state.latest is not None and state.frame_of is state.latest:
            return state.frame
        if state.latest is None and clock.paused:
            return None  # no image at this position, and none is coming
        waiter: asyncio.Future[FrameEvent | None] = asyncio.get_running_loop().create_future()
        state.waiters.append(waiter)
        self._encode(state)
        try:
            return await asyncio.wait_for(waiter, SNAPSHOT_TIMEOUT)
        except TimeoutError:
            return None
        finally:
            if waiter in state.waiters:
                state.waiters.remove(waiter)
