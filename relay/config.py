"""robots.yaml: the fleet, its topics, limits and the simulator's world, validated with line numbers.

``load_config(path)`` returns a frozen :class:`FleetConfig` or raises :class:`~relay.errors.ConfigError`
whose text names the file, the line, the field and what was expected::

    robots.yaml:14: robots[1].limits.linear: expected a positive number, got "fast"

Every field and default is documented in docs/configuration.md. Topic defaults follow the namespace
convention (``/<ns>/odom``, ``/<ns>/cmd_vel``, ``/<ns>/goal_pose``, ``/<ns>/camera/image_raw``); a relative
topic is resolved inside the robot's namespace and an absolute one is used as written.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, TypeVar

import yaml
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from .errors import ConfigError
from .protocol import ROBOT_NAME_PATTERN
from .rosmsg import SENSOR_TYPES

PoseSourceKind = Literal["tf", "odom", "amcl_pose", "pose"]
POSE_SOURCES: tuple[PoseSourceKind, ...] = ("tf", "odom", "amcl_pose", "pose")
LENS_MODELS = ("equidistant", "equisolid", "stereographic", "pinhole", "opencv_fisheye")

_TOPIC = re.compile(r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$")
_FRAME = re.compile(r"^[A-Za-z0-9_./-]{1,128}$")
_COLOUR = re.compile(r"^#[0-9a-fA-F]{6}$")


@dataclass(frozen=True)
class Lens:
    model: str
    fov: float  # degrees
    k: tuple[float, ...] | None = None  # 3x3 row-major intrinsics (opencv_fisheye)
    d: tuple[float, ...] | None = None  # k1..k4 (opencv_fisheye)


@dataclass(frozen=True)
class Camera:
    name: str
    topic: str
    compressed: bool
    lens: Lens
    width: int
    height: int
    rate: float  # highest rate the relay streams this camera at, frames per second


@dataclass(frozen=True)
class Sensor:
    name: str
    topic: str
    type: str
    unit: str
    warn_above: float | None
    warn_below: float | None
    hazard: str  # the simulator's sensor field that drives it

    def is_warning(self, value: float) -> bool:
        return (self.warn_above is not None and value > self.warn_above) or (
            self.warn_below is not None and value < self.warn_below
        )


@dataclass(frozen=True)
class PoseSource:
    source: PoseSourceKind
    topic: str
    map_frame: str
    odom_frame: str
    base_frame: str


@dataclass(frozen=True)
class Limits:
    linear: float  # m/s
    angular: float  # rad/s


@dataclass(frozen=True)
class Pose2D:
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class ModelSource:
    """Build the robot's model from its URDF, published on ``topic`` (std_msgs/String, as robot_state_publisher
    does); ``packages`` are the directories where ``package://`` meshes are looked up."""

    topic: str
    packages: tuple[Path, ...]


@dataclass(frozen=True)
class Robot:
    name: str
    namespace: str
    colour: str
    model: str | None
    pose: PoseSource
    cmd_vel_topic: str
    cmd_vel_stamped: bool
    goal_topic: str
    cameras: tuple[Camera, ...]
    sensors: tuple[Sensor, ...]
    limits: Limits
    initial_pose: Pose2D
    scan_topic: str | None = None  # sensor_msgs/LaserScan; None: no scan
    model_source: ModelSource | None = None

    def camera(self, name: str | None) -> Camera | None:
        """The named camera, or the first one when ``name`` is None."""
        if name is None:
            return self.cameras[0] if self.cameras else None
        return next((c for c in self.cameras if c.name == name), None)


@dataclass(frozen=True)
class MapToScene:
    """Where the map frame sits in the scene, both in ROS conventions (z up); see docs/configuration.md."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class Scene:
    url: str | None
    map_to_scene: MapToScene


@dataclass(frozen=True)
class Hazard:
    kind: str
    x: float
    y: float
    peak: float
    sigma: float


@dataclass(frozen=True)
class Field:
    kind: str
    baseline: float
    noise: float


@dataclass(frozen=True)
class Sim:
    world: Path | None = None  # a facility.yaml (scene tool output): occupancy grid and hazard sources
    physics_rate: float = 50.0
    pose_rate: float = 30.0
    sensor_rate: float = 5.0
    hazards: tuple[Hazard, ...] = ()
    fields: tuple[Field, ...] = ()


@dataclass(frozen=True)
class Safety:
    deadman_timeout: float = 0.5
    offline_after: float = 2.0


QOS_NAMES = ("pose", "sensors", "scan", "images", "commands", "map")
Reliability = Literal["reliable", "best_effort"]


@dataclass(frozen=True)
class Ros:
    """Settings of the ``ros`` backend."""

    map_topic: str = "/map"
    #: Reliability per kind of topic; depth and durability are fixed (images depth 1, map transient local).
    qos: tuple[tuple[str, Reliability], ...] = (
        ("pose", "best_effort"),
        ("sensors", "best_effort"),
        ("scan", "best_effort"),
        # Reliable, depth 1: best effort loses most large images whose fragments drop (0.6 of 30 fps for
        # 640x480 rgb8 vs 25 fps reliable, bench/bench_camera.py); depth 1 still bounds the queue.
        ("images", "reliable"),
        ("commands", "reliable"),
        ("map", "reliable"),
    )

    def reliability(self, kind: str) -> Reliability:
        return dict(self.qos)[kind]


@dataclass(frozen=True)
class FleetConfig:
    source: str
    robots: tuple[Robot, ...]
    scene: Scene = field(default_factory=lambda: Scene(None, MapToScene()))
    map: Path | None = None
    sim: Sim = field(default_factory=Sim)
    safety: Safety = field(default_factory=Safety)
    ros: Ros = field(default_factory=Ros)

    def robot(self, name: str) -> Robot | None:
        return next((r for r in self.robots if r.name == name), None)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.robots)


# --------------------------------------------------------------------------------------------------
# Reading YAML nodes with their line numbers
# --------------------------------------------------------------------------------------------------

T = TypeVar("T")


class _Reader:
    """Walks the composed YAML node tree so that every error can name its line."""

    def __init__(self, file: str) -> None:
        self.file = file
        self._constructor = SafeConstructor()

    def fail(self, node: Node | None, path: str, message: str) -> ConfigError:
        line = node.start_mark.line + 1 if node is not None else None
        return ConfigError(self.file, line, path, message)

    def value(self, node: Node) -> Any:
        return self._constructor.construct_object(node, deep=True)

    def show(self, node: Node) -> str:
        if isinstance(node, ScalarNode):
            value = self.value(node)
            return "nothing" if value is None else f'"{value}"' if isinstance(value, str) else str(value)
        return "a list" if isinstance(node, SequenceNode) else "a mapping"

    def mapping(
        self, node: Node, path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()
    ) -> dict[str, Node]:
        if not isinstance(node, MappingNode):
            raise self.fail(node, path, f"expected a mapping, got {self.show(node)}")
        out: dict[str, Node] = {}
        for key_node, value_node in node.value:
            key = self.value(key_node)
            if not isinstance(key, str):
                raise self.fail(key_node, path, f"keys must be strings, got {self.show(key_node)}")
            if key in out:
                raise self.fail(key_node, _join(path, key), "appears twice")
            if key not in allowed:
                raise self.fail(key_node, _join(path, key), "unknown field; expected one of " + ", ".join(allowed))
            out[key] = value_node
        for key in required:
            if key not in out:
                raise self.fail(node, _join(path, key), "is required")
        return out

    def sequence(self, node: Node, path: str) -> Iterator[tuple[int, Node]]:
        if not isinstance(node, SequenceNode):
            raise self.fail(node, path, f"expected a list, got {self.show(node)}")
        return enumerate(node.value)

    def number(self, node: Node, path: str, *, positive: bool = False, non_negative: bool = False) -> float:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
            number = float(value)
            if not ((positive and number <= 0) or (non_negative and number < 0)):
                return number
        what = "a positive number" if positive else "a number >= 0" if non_negative else "a number"
        raise self.fail(node, path, f"expected {what}, got {self.show(node)}")

    def optional_number(self, node: Node | None, path: str) -> float | None:
        if node is None or (isinstance(node, ScalarNode) and self.value(node) is None):
            return None
        return self.number(node, path)

    def integer(self, node: Node, path: str) -> int:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, int) or isinstance(value, bool) or value <= 0:
            raise self.fail(node, path, f"expected a positive integer, got {self.show(node)}")
        return value

    def boolean(self, node: Node, path: str) -> bool:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, bool):
            raise self.fail(node, path, f"expected true or false, got {self.show(node)}")
        return value

    def string(
        self, node: Node, path: str, *, pattern: re.Pattern[str] | None = None, expected: str = "a string"
    ) -> str:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, str) or not value or (pattern is not None and not pattern.match(value)):
            raise self.fail(node, path, f"expected {expected}, got {self.show(node)}")
        return value

    def choice(self, node: Node, path: str, choices: tuple[str, ...]) -> str:
        value = self.value(node) if isinstance(node, ScalarNode) else None
        if value not in choices:
            raise self.fail(node, path, "expected one of " + ", ".join(choices) + f", got {self.show(node)}")
        assert isinstance(value, str)
        return value

    def get(self, fields: dict[str, Node], key: str, path: str, read: Callable[[Node, str], T], default: T) -> T:
        node = fields.get(key)
        if node is None:
            return default
        return read(node, _join(path, key))


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _topic(reader: _Reader, node: Node, path: str, namespace: str) -> str:
    value = reader.string(node, path, pattern=_TOPIC, expected="a ROS topic name such as /robot1/odom")
    return resolve_topic(namespace, value)


def resolve_topic(namespace: str, name: str) -> str:
    """An absolute topic as written; a relative one inside ``namespace`` (``""`` is the root)."""
    if name.startswith("/"):
        return name
    return f"{namespace.rstrip('/')}/{name}"


# --------------------------------------------------------------------------------------------------
# The schema
# --------------------------------------------------------------------------------------------------


def load_config(path: str | Path) -> FleetConfig:
    """Read and validate a robots.yaml file."""
    path = Path(path)
    display = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(display, None, "", f"cannot read the file: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise ConfigError(display, None, "", "the file is not UTF-8 text") from None
    return parse_config(text, display, base_dir=path.parent)


def parse_config(text: str, file: str = "robots.yaml", base_dir: Path | None = None) -> FleetConfig:
    """Validate robots.yaml text; ``file`` names it in errors, ``base_dir`` resolves relative paths."""
    reader = _Reader(file)
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        line = exc.problem_mark.line + 1 if exc.problem_mark is not None else None
        raise ConfigError(file, line, "", f"not valid YAML: {exc.problem}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(file, None, "", f"not valid YAML: {exc}") from None
    if root is None:
        raise ConfigError(file, None, "", "the file is empty; it needs at least a 'robots' list")

    top = reader.mapping(root, "", ("robots", "scene", "map", "sim", "safety", "ros"), required=("robots",))
    scene = _scene(reader, top["scene"]) if "scene" in top else Scene(None, MapToScene())
    map_path: Path | None = None
    if "map" in top and reader.value(top["map"]) is not None:
        map_path = Path(reader.string(top["map"], "map", expected="a path to a map.yaml"))
        if base_dir is not None and not map_path.is_absolute():
            map_path = base_dir / map_path
    sim = _sim(reader, top["sim"], base_dir) if "sim" in top else Sim()
    safety = _safety(reader, top["safety"]) if "safety" in top else Safety()
    ros = _ros(reader, top["ros"]) if "ros" in top else Ros()

    robots: list[Robot] = []
    for index, node in reader.sequence(top["robots"], "robots"):
        robot = _robot(reader, node, f"robots[{index}]", base_dir)
        if any(r.name == robot.name for r in robots):
            raise reader.fail(node, f"robots[{index}].name", f'duplicate robot name "{robot.name}"')
        robots.append(robot)
    if not robots:
        raise reader.fail(top["robots"], "robots", "expected at least one robot")
    return FleetConfig(source=file, robots=tuple(robots), scene=scene, map=map_path, sim=sim, safety=safety, ros=ros)


def _scene(reader: _Reader, node: Node) -> Scene:
    fields = reader.mapping(node, "scene", ("url", "map_to_scene"))
    url = None
    if "url" in fields and reader.value(fields["url"]) is not None:
        url = reader.string(fields["url"], "scene.url", expected="a URL such as /scenes/facility.glb")
    transform = MapToScene()
    if "map_to_scene" in fields:
        path = "scene.map_to_scene"
        t = reader.mapping(fields["map_to_scene"], path, ("x", "y", "z", "yaw"))
        transform = MapToScene(*(reader.get(t, k, path, reader.number, 0.0) for k in ("x", "y", "z", "yaw")))
    return Scene(url, transform)


def _sim(reader: _Reader, node: Node, base_dir: Path | None) -> Sim:
    path = "sim"
    f = reader.mapping(node, path, ("world", "physics_rate", "pose_rate", "sensor_rate", "hazards", "fields"))
    world: Path | None = None
    if "world" in f and reader.value(f["world"]) is not None:
        world = Path(reader.string(f["world"], "sim.world", expected="a path to a facility.yaml"))
        if base_dir is not None and not world.is_absolute():
            world = base_dir / world
        if not world.is_file():
            raise reader.fail(f["world"], "sim.world", f"no such file: {world}")

    def rate(n: Node, p: str) -> float:
        return reader.number(n, p, positive=True)

    hazards: list[Hazard] = []
    if "hazards" in f:
        for i, hnode in reader.sequence(f["hazards"], "sim.hazards"):
            hp = f"sim.hazards[{i}]"
            h = reader.mapping(hnode, hp, ("kind", "x", "y", "peak", "sigma"), required=("kind", "x", "y"))
            hazards.append(
                Hazard(
                    kind=reader.string(h["kind"], f"{hp}.kind"),
                    x=reader.number(h["x"], f"{hp}.x"),
                    y=reader.number(h["y"], f"{hp}.y"),
                    peak=reader.get(h, "peak", hp, reader.number, 1.0),
                    sigma=reader.get(h, "sigma", hp, rate, 1.0),
                )
            )
    fields: list[Field] = []
    if "fields" in f:
        path_f = "sim.fields"
        if not isinstance(f["fields"], MappingNode):
            raise reader.fail(f["fields"], path_f, f"expected a mapping, got {reader.show(f['fields'])}")
        for key_node, value_node in f["fields"].value:
            kind = reader.string(key_node, path_f, expected="a sensor field name")
            fp = f"{path_f}.{kind}"
            v = reader.mapping(value_node, fp, ("baseline", "noise"))
            fields.append(
                Field(
                    kind=kind,
                    baseline=reader.get(v, "baseline", fp, reader.number, 0.0),
                    noise=reader.get(v, "noise", fp, lambda n, p: reader.number(n, p, non_negative=True), 0.0),
                )
            )
    return Sim(
        world=world,
        physics_rate=reader.get(f, "physics_rate", path, rate, 50.0),
        pose_rate=reader.get(f, "pose_rate", path, rate, 30.0),
        sensor_rate=reader.get(f, "sensor_rate", path, rate, 5.0),
        hazards=tuple(hazards),
        fields=tuple(fields),
    )


def _safety(reader: _Reader, node: Node) -> Safety:
    f = reader.mapping(node, "safety", ("deadman_timeout", "offline_after"))

    def positive(n: Node, p: str) -> float:
        return reader.number(n, p, positive=True)

    return Safety(
        deadman_timeout=reader.get(f, "deadman_timeout", "safety", positive, 0.5),
        offline_after=reader.get(f, "offline_after", "safety", positive, 2.0),
    )


def _ros(reader: _Reader, node: Node) -> Ros:
    f = reader.mapping(node, "ros", ("map_topic", "qos"))
    map_topic = Ros.map_topic
    if "map_topic" in f:
        map_topic = _topic(reader, f["map_topic"], "ros.map_topic", "")
    qos = dict(Ros.qos)
    if "qos" in f:
        q = reader.mapping(f["qos"], "ros.qos", QOS_NAMES)
        for key, value in q.items():
            qos[key] = reader.choice(value, f"ros.qos.{key}", ("reliable", "best_effort"))  # type: ignore[assignment]
    return Ros(map_topic=map_topic, qos=tuple(qos.items()))


_ROBOT_FIELDS = (
    "name",
    "namespace",
    "colour",
    "model",
    "pose",
    "cmd_vel",
    "goal_pose",
    "cameras",
    "sensors",
    "limits",
    "initial_pose",
    "scan",
)


def _robot(reader: _Reader, node: Node, path: str, base_dir: Path | None) -> Robot:
    f = reader.mapping(node, path, _ROBOT_FIELDS, required=("name", "limits"))
    name = reader.string(
        f["name"], f"{path}.name", pattern=ROBOT_NAME_PATTERN, expected="a name of letters, digits and _"
    )
    namespace = f"/{name}"
    if "namespace" in f:
        raw = reader.value(f["namespace"])
        if raw in (None, "", "/"):
            namespace = ""
        else:
            namespace = "/" + reader.string(
                f["namespace"], f"{path}.namespace", pattern=_TOPIC, expected="a ROS namespace such as /robot1"
            ).strip("/")
    colour = reader.get(
        f,
        "colour",
        path,
        lambda n, p: reader.string(n, p, pattern=_COLOUR, expected="a colour like #e6194b"),
        "#4363d8",
    )
    model = None
    model_source = None
    if "model" in f and isinstance(f["model"], MappingNode):
        mp = f"{path}.model"
        m = reader.mapping(f["model"], mp, ("robot_description", "packages"))
        topic = resolve_topic(namespace, "robot_description")
        if "robot_description" in m:
            topic = _topic(reader, m["robot_description"], f"{mp}.robot_description", namespace)
        packages: list[Path] = []
        for i, pnode in reader.sequence(m["packages"], f"{mp}.packages") if "packages" in m else ():
            package = Path(reader.string(pnode, f"{mp}.packages[{i}]", expected="a directory"))
            if base_dir is not None and not package.is_absolute():
                package = base_dir / package
            packages.append(package)
        model_source = ModelSource(topic, tuple(packages))
    elif "model" in f and reader.value(f["model"]) is not None:
        model = reader.string(f["model"], f"{path}.model", expected="a URL of a glTF model")

    pose = _pose_source(reader, f.get("pose"), f"{path}.pose", namespace)

    cmd_vel_topic = resolve_topic(namespace, "cmd_vel")
    stamped = False
    if "cmd_vel" in f:
        c = reader.mapping(f["cmd_vel"], f"{path}.cmd_vel", ("topic", "stamped"))
        if "topic" in c:
            cmd_vel_topic = _topic(reader, c["topic"], f"{path}.cmd_vel.topic", namespace)
        stamped = reader.get(c, "stamped", f"{path}.cmd_vel", reader.boolean, False)
    goal_topic = resolve_topic(namespace, "goal_pose")
    if "goal_pose" in f:
        g = reader.mapping(f["goal_pose"], f"{path}.goal_pose", ("topic",))
        if "topic" in g:
            goal_topic = _topic(reader, g["topic"], f"{path}.goal_pose.topic", namespace)

    cameras: list[Camera] = []
    for i, cnode in reader.sequence(f["cameras"], f"{path}.cameras") if "cameras" in f else ():
        cam = _camera(reader, cnode, f"{path}.cameras[{i}]", namespace)
        for other in cameras:
            if other.name == cam.name:
                raise reader.fail(cnode, f"{path}.cameras[{i}].name", f'duplicate camera name "{cam.name}"')
            if other.topic == cam.topic:
                raise reader.fail(
                    cnode,
                    f"{path}.cameras[{i}].topic",
                    f'topic {cam.topic} is already used by camera "{other.name}"; set topic explicitly',
                )
        cameras.append(cam)
    sensors: list[Sensor] = []
    for i, snode in reader.sequence(f["sensors"], f"{path}.sensors") if "sensors" in f else ():
        sensor = _sensor(reader, snode, f"{path}.sensors[{i}]", namespace)
        if any(s.name == sensor.name for s in sensors):
            raise reader.fail(snode, f"{path}.sensors[{i}].name", f'duplicate sensor name "{sensor.name}"')
        sensors.append(sensor)

    lp = f"{path}.limits"
    lim = reader.mapping(f["limits"], lp, ("linear", "angular"), required=("linear", "angular"))
    limits = Limits(
        linear=reader.number(lim["linear"], f"{lp}.linear", positive=True),
        angular=reader.number(lim["angular"], f"{lp}.angular", positive=True),
    )
    initial = Pose2D(0.0, 0.0, 0.0)
    if "initial_pose" in f:
        ip = f"{path}.initial_pose"
        p = reader.mapping(f["initial_pose"], ip, ("x", "y", "yaw"), required=("x", "y"))
        initial = Pose2D(
            reader.number(p["x"], f"{ip}.x"),
            reader.number(p["y"], f"{ip}.y"),
            reader.get(p, "yaw", ip, reader.number, 0.0),
        )
    scan_topic: str | None = resolve_topic(namespace, "scan")
    if "scan" in f:
        raw_scan = reader.value(f["scan"])
        if raw_scan is None or raw_scan is False:
            scan_topic = None
        else:
            sc = reader.mapping(f["scan"], f"{path}.scan", ("topic",))
            if "topic" in sc:
                scan_topic = _topic(reader, sc["topic"], f"{path}.scan.topic", namespace)
    return Robot(
        model_source=model_source,
        scan_topic=scan_topic,
        name=name,
        namespace=namespace,
        colour=colour,
        model=model,
        pose=pose,
        cmd_vel_topic=cmd_vel_topic,
        cmd_vel_stamped=stamped,
        goal_topic=goal_topic,
        cameras=tuple(cameras),
        sensors=tuple(sensors),
        limits=limits,
        initial_pose=initial,
    )


_DEFAULT_POSE_TOPIC: dict[PoseSourceKind, str] = {
    "tf": "tf",
    "odom": "odom",
    "amcl_pose": "amcl_pose",
    "pose": "pose",
}


def _pose_source(reader: _Reader, node: Node | None, path: str, namespace: str) -> PoseSource:
    source: PoseSourceKind = "odom"
    fields: dict[str, Node] = {}
    if node is not None and isinstance(node, ScalarNode):
        source = reader.choice(node, f"{path}", POSE_SOURCES)  # type: ignore[assignment]
    elif node is not None:
        fields = reader.mapping(
            node, path, ("source", "topic", "map_frame", "odom_frame", "base_frame"), required=("source",)
        )
        source = reader.choice(fields["source"], f"{path}.source", POSE_SOURCES)  # type: ignore[assignment]
    topic = resolve_topic(namespace, _DEFAULT_POSE_TOPIC[source])
    if "topic" in fields:
        topic = _topic(reader, fields["topic"], f"{path}.topic", namespace)

    def frame(n: Node, p: str) -> str:
        return reader.string(n, p, pattern=_FRAME, expected="a TF frame name")

    return PoseSource(
        source=source,
        topic=topic,
        map_frame=reader.get(fields, "map_frame", path, frame, "map"),
        odom_frame=reader.get(fields, "odom_frame", path, frame, "odom"),
        base_frame=reader.get(fields, "base_frame", path, frame, "base_footprint"),
    )


def _camera(reader: _Reader, node: Node, path: str, namespace: str) -> Camera:
    f = reader.mapping(
        node, path, ("name", "topic", "compressed", "lens", "width", "height", "rate"), required=("name",)
    )
    name = reader.string(f["name"], f"{path}.name", pattern=ROBOT_NAME_PATTERN, expected="a camera name")
    compressed = reader.get(f, "compressed", path, reader.boolean, False)
    default = "camera/image_raw/compressed" if compressed else "camera/image_raw"
    topic = resolve_topic(namespace, default)
    if "topic" in f:
        topic = _topic(reader, f["topic"], f"{path}.topic", namespace)
    lens = Lens("equidistant", 180.0)
    if "lens" in f:
        lp = f"{path}.lens"
        ln = reader.mapping(f["lens"], lp, ("model", "fov", "K", "D"), required=("model",))
        model = reader.choice(ln["model"], f"{lp}.model", LENS_MODELS)
        fov = reader.get(ln, "fov", lp, lambda n, p: reader.number(n, p, positive=True), 180.0)
        if fov >= 360.0 or (model == "pinhole" and fov >= 180.0):
            limit = "180 for pinhole" if model == "pinhole" else "360"
            raise reader.fail(ln.get("fov"), f"{lp}.fov", f"expected degrees below {limit}, got {fov:g}")
        k = _numbers(reader, ln.get("K"), f"{lp}.K", 9)
        d = _numbers(reader, ln.get("D"), f"{lp}.D", 4)
        if model == "opencv_fisheye" and (k is None or d is None):
            raise reader.fail(f["lens"], lp, "opencv_fisheye needs K (9 numbers) and D (4 numbers)")
        lens = Lens(model, fov, k, d)
    return Camera(
        name=name,
        topic=topic,
        compressed=compressed,
        lens=lens,
        width=reader.get(f, "width", path, reader.integer, 640),
        height=reader.get(f, "height", path, reader.integer, 640),
        rate=reader.get(f, "rate", path, lambda n, p: reader.number(n, p, positive=True), 30.0),
    )


def _numbers(reader: _Reader, node: Node | None, path: str, count: int) -> tuple[float, ...] | None:
    if node is None:
        return None
    items = [reader.number(n, f"{path}[{i}]") for i, n in reader.sequence(node, path)]
    if len(items) != count:
        raise reader.fail(node, path, f"expected {count} numbers, got {len(items)}")
    return tuple(items)


def _sensor(reader: _Reader, node: Node, path: str, namespace: str) -> Sensor:
    f = reader.mapping(
        node,
        path,
        ("name", "topic", "type", "unit", "warn_above", "warn_below", "hazard"),
        required=("name", "type"),
    )
    name = reader.string(f["name"], f"{path}.name", pattern=ROBOT_NAME_PATTERN, expected="a sensor name")
    raw_type = reader.string(f["type"], f"{path}.type", expected="a message type")
    package, _, rest = raw_type.partition("/")
    msg_type = raw_type if rest.startswith("msg/") else f"{package}/msg/{rest}"
    if msg_type not in SENSOR_TYPES:
        raise reader.fail(
            f["type"],
            f"{path}.type",
            "expected one of " + ", ".join(t.replace("/msg/", "/") for t in SENSOR_TYPES) + f', got "{raw_type}"',
        )
    topic = resolve_topic(namespace, name)
    if "topic" in f:
        topic = _topic(reader, f["topic"], f"{path}.topic", namespace)
    unit = SENSOR_TYPES[msg_type].unit
    if "unit" in f:
        unit_value = reader.value(f["unit"])
        if not isinstance(unit_value, str):
            raise reader.fail(f["unit"], f"{path}.unit", f"expected a string, got {reader.show(f['unit'])}")
        unit = unit_value
    above = reader.optional_number(f.get("warn_above"), f"{path}.warn_above")
    below = reader.optional_number(f.get("warn_below"), f"{path}.warn_below")
    if above is not None and below is not None and below >= above:
        raise reader.fail(f["warn_below"], f"{path}.warn_below", f"must be below warn_above ({above:g})")
    hazard = reader.get(f, "hazard", path, lambda n, p: reader.string(n, p), name)
    return Sensor(name, topic, msg_type, unit, above, below, hazard)
