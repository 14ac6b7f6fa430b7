"""Which robot each recording plays as: bags bound to robots of robots.yaml (pure: no I/O beyond a stat)."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ...config import Camera, CloudSource, FleetConfig, Robot, Sensor
from ...errors import BackendUnavailable
from ...ros.rosmsg import MAP_TYPE, POSE_TYPES, SCAN_TYPE, image_type
from ...session.protocol import ROBOT_NAME_PATTERN

logger = logging.getLogger(__name__)


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
    #: Its cloud sources (robots.yaml ``clouds``): the source, its topic, and a depth image's CameraInfo topic.
    clouds: tuple[tuple[CloudSource, str, str | None], ...] = ()
    #: /tf_static, read for the clouds' frames (also with a pose source other than tf).
    cloud_static: str | None = None

    def describe(self) -> str:
        parts = [f"pose {self.pose}"]
        if self.scan:
            parts.append(f"scan {self.scan}")
        parts += [f"{s.name} {t}" for s, t in self.sensors]
        parts += [f"camera {c.name} {t}" for c, t in self.cameras]
        parts += [f"cloud {c.name} {t}" for c, t, _ in self.clouds]
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

    def found(topic: str, label: str, expected: str) -> str | None:
        """The bag's topic for a configured one, type-checked; None (and noted as missing) when absent."""
        name = _lookup(topic, robot, topics, strip)
        if name is None:
            missing.append(f"{label} {topic}")
            return None
        _check_type(spec, name, topics[name], expected, f"{robot.name}'s {label}")
        return name

    sensors = [(s, t) for s in robot.sensors if (t := found(s.topic, f"sensor {s.name}", s.type)) is not None]
    cameras = [
        (c, t) for c in robot.cameras if (t := found(c.topic, f"camera {c.name}", image_type(c.compressed))) is not None
    ]
    clouds: list[tuple[CloudSource, str, str | None]] = []
    for cloud in robot.clouds if config.cloud is not None else ():
        kind = "sensor_msgs/msg/PointCloud2" if cloud.kind == "pointcloud2" else image_type(False)
        topic = found(cloud.topic, f"cloud {cloud.name}", kind)
        info = None
        if cloud.camera_info is not None:
            info = found(cloud.camera_info, f"cloud {cloud.name}'s camera_info", "sensor_msgs/msg/CameraInfo")
        if topic is not None:
            clouds.append((cloud, topic, info))
    cloud_static = tf_static
    if cloud_static is None and any(cloud.mount is None for cloud, _, _ in clouds):
        cloud_static = _lookup(f"{robot.namespace}/tf_static", robot, topics, strip)
        if cloud_static is not None:
            _check_type(spec, cloud_static, topics[cloud_static], POSE_TYPES["tf"], f"{robot.name}'s static TF")
    return RobotTopics(
        robot, pose, tf_static, scan, tuple(sensors), tuple(cameras), tuple(missing), tuple(clouds), cloud_static
    )


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
