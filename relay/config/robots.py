"""The ``robots`` entries of robots.yaml: names, namespaces, topics, pose sources, cameras, sensors, limits, arms."""

from __future__ import annotations

import re
from pathlib import Path
from typing import NamedTuple, cast

from yaml.nodes import MappingNode, Node, ScalarNode

from ..ros.rosmsg import SENSOR_TYPES
from ..session.protocol import ROBOT_NAME_PATTERN
from .arm import arm
from .clouds import clouds
from .model import (
    LENS_MODELS,
    NAV_INTERFACES,
    ON_RELAY_LOST,
    POSE_SOURCES,
    Camera,
    Lens,
    Limits,
    ModelSource,
    NavInterface,
    Pose2D,
    PoseSource,
    PoseSourceKind,
    RelayLost,
    Robot,
    Sensor,
)
from .reader import _COLOUR, _FRAME, _TOPIC, _Reader, _topic, resolve_topic, speed_limits

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
    "plan",
    "navigation",
    "arm",
    "team",
    "clouds",
)
#: A team's name: what a site calls its crews ("North crew", "night-shift", "B2"), short enough for a button.
_TEAM = re.compile(r"^[A-Za-z0-9][A-Za-z0-9 _-]{0,31}$")


def _robot(reader: _Reader, node: Node, path: str, base_dir: Path | None) -> Robot:
    f = reader.mapping(node, path, _ROBOT_FIELDS, required=("name", "limits"))
    name = reader.string(
        f["name"], f"{path}.name", pattern=ROBOT_NAME_PATTERN, expected="a name of letters, digits and _"
    )
    namespace = _namespace(reader, f, path, name)
    colour = reader.get(
        f,
        "colour",
        path,
        lambda n, p: reader.string(n, p, pattern=_COLOUR, expected="a colour like #e6194b"),
        "#4363d8",
    )
    model, model_source = _model(reader, f, path, namespace, base_dir)
    pose = _pose_source(reader, f.get("pose"), f"{path}.pose", namespace)
    cmd_vel_topic, stamped, watchdog_topic, goal_topic = _command_topics(reader, f, path, namespace)
    cameras = _cameras(reader, f, path, namespace)
    sensors = _sensors(reader, f, path, namespace)
    limits, initial = _limits(reader, f, path)
    scan_topic = _optional_topic(reader, f, path, namespace, "scan")
    plan_topic = _optional_topic(reader, f, path, namespace, "plan")
    navigation = _navigation(reader, f, path, namespace, (cmd_vel_topic, watchdog_topic))
    camera_names = tuple(c.name for c in cameras)
    robot_arm = arm(reader, f["arm"], f"{path}.arm", namespace, base_dir, camera_names) if "arm" in f else None
    team_name = "a team name of 1-32 letters, digits, spaces, _ and -"
    team = reader.get(f, "team", path, lambda n, p: reader.string(n, p, pattern=_TEAM, expected=team_name), None)
    sources = clouds(reader, f["clouds"], f"{path}.clouds", namespace) if "clouds" in f else ()
    return Robot(
        clouds=sources,
        model_source=model_source,
        scan_topic=scan_topic,
        plan_topic=plan_topic,
        name=name,
        namespace=namespace,
        colour=colour,
        model=model,
        pose=pose,
        cmd_vel_topic=cmd_vel_topic,
        cmd_vel_stamped=stamped,
        watchdog_topic=watchdog_topic,
        goal_topic=goal_topic,
        cameras=tuple(cameras),
        sensors=tuple(sensors),
        limits=limits,
        initial_pose=initial,
        nav_interface=navigation.interface,
        nav_action=navigation.action,
        autonomy_topic=navigation.autonomy,
        on_relay_lost=navigation.on_relay_lost,
        arm=robot_arm,
        team=team,
    )


def _namespace(reader: _Reader, f: dict[str, Node], path: str, name: str) -> str:
    """``/<name>`` unless robots.yaml says otherwise; ``""`` (or ``/``) is the root namespace."""
    namespace = f"/{name}"
    if "namespace" in f:
        raw = reader.value(f["namespace"])
        if raw in (None, "", "/"):
            namespace = ""
        else:
            namespace = "/" + reader.string(
                f["namespace"], f"{path}.namespace", pattern=_TOPIC, expected="a ROS namespace such as /robot1"
            ).strip("/")
    return namespace


def _model(
    reader: _Reader, f: dict[str, Node], path: str, namespace: str, base_dir: Path | None
) -> tuple[str | None, ModelSource | None]:
    """A glTF URL, or where to build the model from (the robot_description topic and package paths)."""
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
    return model, model_source


def _command_topics(
    reader: _Reader, f: dict[str, Node], path: str, namespace: str
) -> tuple[str, bool, str | None, str]:
    """cmd_vel (whether it is a TwistStamped, and the watchdog's input topic if any) and goal_pose."""
    cmd_vel_topic = resolve_topic(namespace, "cmd_vel")
    stamped = False
    watchdog: str | None = None
    if "cmd_vel" in f:
        c = reader.mapping(f["cmd_vel"], f"{path}.cmd_vel", ("topic", "stamped", "watchdog"))
        if "topic" in c:
            cmd_vel_topic = _topic(reader, c["topic"], f"{path}.cmd_vel.topic", namespace)
        stamped = reader.get(c, "stamped", f"{path}.cmd_vel", reader.boolean, False)
        if "watchdog" in c:
            # true: the default input topic; a string: that topic; false: none (the relay publishes on cmd_vel).
            node, where = c["watchdog"], f"{path}.cmd_vel.watchdog"
            if isinstance(reader.value(node), str):
                watchdog = _topic(reader, node, where, namespace)
            elif reader.boolean(node, where):
                watchdog = resolve_topic(namespace, "xr_relay/cmd_vel")
            if watchdog == cmd_vel_topic:
                raise reader.fail(node, where, "the watchdog's input must be another topic than cmd_vel's")
    goal_topic = resolve_topic(namespace, "goal_pose")
    if "goal_pose" in f:
        g = reader.mapping(f["goal_pose"], f"{path}.goal_pose", ("topic",))
        if "topic" in g:
            goal_topic = _topic(reader, g["topic"], f"{path}.goal_pose.topic", namespace)
    return cmd_vel_topic, stamped, watchdog, goal_topic


class _Navigation(NamedTuple):
    interface: NavInterface
    action: str
    autonomy: str
    on_relay_lost: RelayLost


def _navigation(
    reader: _Reader, f: dict[str, Node], path: str, namespace: str, velocity_topics: tuple[str, str | None]
) -> _Navigation:
    """``navigation:`` (every key optional): how goals reach the robot, and what its watchdog gates."""
    fields: dict[str, Node] = {}
    np = f"{path}.navigation"
    node = f.get("navigation")
    if isinstance(node, ScalarNode) and reader.value(node) is not None:
        fields = {"interface": node}  # the short form: `navigation: topic`
    elif node is not None:
        fields = reader.mapping(node, np, ("interface", "action", "autonomy", "on_relay_lost"))
    interface = cast(
        NavInterface, reader.get(fields, "interface", np, lambda n, p: reader.choice(n, p, NAV_INTERFACES), "nav2")
    )
    action = resolve_topic(namespace, "navigate_to_pose")
    if "action" in fields:
        action = _topic(reader, fields["action"], f"{np}.action", namespace)
    autonomy = resolve_topic(namespace, "cmd_vel_nav")
    if "autonomy" in fields:
        autonomy = _topic(reader, fields["autonomy"], f"{np}.autonomy", namespace)
    if autonomy in velocity_topics:
        # The watchdog reads autonomy and writes cmd_vel: one topic for both would feed its output back in.
        node = fields.get("autonomy", f.get("navigation", f.get("cmd_vel")))
        raise reader.fail(node, f"{np}.autonomy", f"expected a topic other than cmd_vel's and teleop's, got {autonomy}")
    lost = cast(
        RelayLost, reader.get(fields, "on_relay_lost", np, lambda n, p: reader.choice(n, p, ON_RELAY_LOST), "hold")
    )
    return _Navigation(interface, action, autonomy, lost)


def _cameras(reader: _Reader, f: dict[str, Node], path: str, namespace: str) -> list[Camera]:
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
    return cameras


def _sensors(reader: _Reader, f: dict[str, Node], path: str, namespace: str) -> list[Sensor]:
    sensors: list[Sensor] = []
    for i, snode in reader.sequence(f["sensors"], f"{path}.sensors") if "sensors" in f else ():
        sensor = _sensor(reader, snode, f"{path}.sensors[{i}]", namespace)
        if any(s.name == sensor.name for s in sensors):
            raise reader.fail(snode, f"{path}.sensors[{i}].name", f'duplicate sensor name "{sensor.name}"')
        sensors.append(sensor)
    return sensors


def _limits(reader: _Reader, f: dict[str, Node], path: str) -> tuple[Limits, Pose2D]:
    """Velocity limits (required) and the simulator's initial pose."""
    limits = speed_limits(reader, f["limits"], f"{path}.limits")
    initial = Pose2D(0.0, 0.0, 0.0)
    if "initial_pose" in f:
        ip = f"{path}.initial_pose"
        p = reader.mapping(f["initial_pose"], ip, ("x", "y", "yaw"), required=("x", "y"))
        initial = Pose2D(
            reader.number(p["x"], f"{ip}.x"),
            reader.number(p["y"], f"{ip}.y"),
            reader.get(p, "yaw", ip, reader.number, 0.0),
        )
    return limits, initial


def _optional_topic(reader: _Reader, f: dict[str, Node], path: str, namespace: str, field: str) -> str | None:
    """A topic the robot may have (``scan``, ``plan``): ``{topic: ...}``, default the field's name in the robot's
    namespace; ``null`` or ``false`` turns it off."""
    topic: str | None = resolve_topic(namespace, field)
    if field in f:
        raw = reader.value(f[field])
        if raw is None or raw is False:
            topic = None
        else:
            fields = reader.mapping(f[field], f"{path}.{field}", ("topic",))
            if "topic" in fields:
                topic = _topic(reader, fields["topic"], f"{path}.{field}.topic", namespace)
    return topic


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
        node,
        path,
        ("name", "topic", "compressed", "lens", "width", "height", "rate", "bitrate"),
        required=("name",),
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
        bitrate=reader.get(f, "bitrate", path, reader.integer, None),
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
