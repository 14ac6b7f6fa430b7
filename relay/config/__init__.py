"""robots.yaml: the fleet, its topics, limits and the simulator's world, validated with line numbers.

``load_config(path)`` returns a frozen :class:`FleetConfig` or raises :class:`~relay.errors.ConfigError`
whose text names the file, the line, the field and what was expected::

    robots.yaml:14: robots[1].limits.linear: expected a positive number, got "fast"

Every field and default is documented in docs/configuration.md. Topic defaults follow the namespace
convention (``/<ns>/odom``, ``/<ns>/cmd_vel``, ``/<ns>/goal_pose``, ``/<ns>/camera/image_raw``); a relative
topic is resolved inside the robot's namespace and an absolute one is used as written.
"""

from __future__ import annotations

import re
import zoneinfo
from pathlib import Path

from yaml.nodes import MappingNode, Node, ScalarNode

from ..errors import ConfigError
from ..inspection.kml import Georeference
from ..session.protocol import MAX_SCAN_RATE
from .cloud import cloud
from .model import (
    LENS_MODELS,
    POSE_SOURCES,
    QOS_NAMES,
    ZENOH_KEYS,
    ZENOH_MODES,
    Arm,
    ArmTopics,
    Camera,
    Cloud,
    CloudSource,
    Field,
    FleetConfig,
    Hazard,
    InspectionSettings,
    Lens,
    Limits,
    MapToScene,
    ModelSource,
    Mount,
    Pose2D,
    PoseSource,
    PoseSourceKind,
    Reliability,
    Robot,
    Ros,
    Safety,
    Scene,
    Sensor,
    Sim,
    Site,
    SpillGrowth,
    Valve,
    Webhook,
    Workspace,
    Zenoh,
)
from .reader import _Reader, _topic, compose, resolve_topic
from .robots import _robot
from .valve import valve
from .webhooks import webhooks

__all__ = [
    "LENS_MODELS",
    "POSE_SOURCES",
    "QOS_NAMES",
    "Arm",
    "ArmTopics",
    "Camera",
    "Cloud",
    "CloudSource",
    "Field",
    "FleetConfig",
    "Hazard",
    "InspectionSettings",
    "Lens",
    "Limits",
    "MapToScene",
    "ModelSource",
    "Mount",
    "Pose2D",
    "PoseSource",
    "PoseSourceKind",
    "Reliability",
    "Robot",
    "Ros",
    "Safety",
    "Scene",
    "Sensor",
    "Sim",
    "Site",
    "SpillGrowth",
    "Valve",
    "Webhook",
    "Workspace",
    "Zenoh",
    "load_config",
    "parse_config",
    "resolve_topic",
]


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
    root = compose(text, file)
    if root is None:
        raise ConfigError(file, None, "", "the file is empty; it needs at least a 'robots' list")

    top = reader.mapping(
        root,
        "",
        ("robots", "scene", "map", "sim", "safety", "ros", "zenoh", "georeference", "inspection", "site", "cloud"),
        required=("robots",),
    )
    scene = _scene(reader, top["scene"]) if "scene" in top else Scene(None, MapToScene())
    map_path: Path | None = None
    if "map" in top and reader.value(top["map"]) is not None:
        map_path = Path(reader.string(top["map"], "map", expected="a path to a map.yaml"))
        if base_dir is not None and not map_path.is_absolute():
            map_path = base_dir / map_path
    sim = _sim(reader, top["sim"], base_dir) if "sim" in top else Sim()
    safety = _safety(reader, top["safety"]) if "safety" in top else Safety()
    ros = _ros(reader, top["ros"], base_dir) if "ros" in top else Ros()
    zenoh = _zenoh(reader, top["zenoh"]) if "zenoh" in top else Zenoh()
    georeference = _georeference(reader, top["georeference"]) if "georeference" in top else None
    inspection = _inspection(reader, top["inspection"]) if "inspection" in top else InspectionSettings()
    site = _site(reader, top["site"]) if "site" in top else Site()
    cloud_settings = cloud(reader, top["cloud"]) if "cloud" in top else None

    robots: list[Robot] = []
    for index, node in reader.sequence(top["robots"], "robots"):
        robot = _robot(reader, node, f"robots[{index}]", base_dir)
        if any(r.name == robot.name for r in robots):
            raise reader.fail(node, f"robots[{index}].name", f'duplicate robot name "{robot.name}"')
        robots.append(robot)
    if not robots:
        raise reader.fail(top["robots"], "robots", "expected at least one robot")
    return FleetConfig(
        source=file, robots=tuple(robots), scene=scene, map=map_path, sim=sim, safety=safety, ros=ros,
        zenoh=zenoh, georeference=georeference, inspection=inspection, site=site, cloud=cloud_settings,
    )  # fmt: skip


def _georeference(reader: _Reader, node: Node) -> Georeference:
    """Where the map frame is on Earth, for KML/KMZ placemarks (relay/inspection/kml.py)."""
    f = reader.mapping(node, "georeference", ("lat", "lon", "yaw"), required=("lat", "lon"))
    lat = reader.number(f["lat"], "georeference.lat")
    lon = reader.number(f["lon"], "georeference.lon")
    yaw = reader.get(f, "yaw", "georeference", reader.number, 0.0)
    try:
        return Georeference(lat, lon, yaw)
    except ValueError as exc:
        raise reader.fail(node, "georeference", str(exc)) from None


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
    keys = (
        "world", "physics_rate", "pose_rate", "sensor_rate", "scan_rate", "hazards", "fields", "spill_growth", "valve",
    )  # fmt: skip
    f = reader.mapping(node, path, keys)
    world: Path | None = None
    if "world" in f and reader.value(f["world"]) is not None:
        world = Path(reader.string(f["world"], "sim.world", expected="a path to a facility.yaml"))
        if base_dir is not None and not world.is_absolute():
            world = base_dir / world
        if not world.is_file():
            raise reader.fail(f["world"], "sim.world", f"no such file: {world}")

    def rate(n: Node, p: str) -> float:
        return reader.number(n, p, positive=True)

    def scan_rate(n: Node, p: str) -> float:
        value = rate(n, p)
        if value > MAX_SCAN_RATE:
            raise reader.fail(n, p, f"at most {MAX_SCAN_RATE:g} Hz (the relay sends no more scans), got {value:g}")
        return value

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
        scan_rate=reader.get(f, "scan_rate", path, scan_rate, 5.0),
        hazards=tuple(hazards),
        fields=tuple(fields),
        spill_growth=_spill_growth(reader, f["spill_growth"]) if "spill_growth" in f else SpillGrowth(),
        valve=valve(reader, f["valve"]) if "valve" in f else None,
    )


def _spill_growth(reader: _Reader, node: Node) -> SpillGrowth:
    path = "sim.spill_growth"
    f = reader.mapping(node, path, ("rate", "limit"))
    rate = reader.get(f, "rate", path, lambda n, p: reader.number(n, p, non_negative=True), SpillGrowth.rate)
    limit = reader.get(f, "limit", path, reader.number, SpillGrowth.limit)
    if limit < 1.0:
        raise reader.fail(f["limit"], f"{path}.limit", f"expected a number >= 1 (times the first size), got {limit:g}")
    return SpillGrowth(rate, limit)


def _inspection(reader: _Reader, node: Node) -> InspectionSettings:
    f = reader.mapping(node, "inspection", ("max_targets", "webhooks"))
    return InspectionSettings(
        max_targets=reader.get(f, "max_targets", "inspection", reader.integer, InspectionSettings.max_targets),
        webhooks=webhooks(reader, f["webhooks"]) if "webhooks" in f else (),
    )


def _site(reader: _Reader, node: Node) -> Site:
    f = reader.mapping(node, "site", ("name", "time_zone"))
    name = reader.get(f, "name", "site", reader.string, None)
    zone = reader.get(f, "time_zone", "site", reader.string, None)
    if zone is not None:
        try:
            zoneinfo.ZoneInfo(zone)
        except (ValueError, zoneinfo.ZoneInfoNotFoundError):
            raise reader.fail(f["time_zone"], "site.time_zone", f"no time zone {zone[:64]!r}: expected an IANA name "
                              "such as Europe/Berlin") from None  # fmt: skip
    if name is not None and len(name) > 200:
        raise reader.fail(f["name"], "site.name", f"expected at most 200 characters, got {len(name)}")
    return Site(name, zone)


ESTOP_RESETS = ("anyone", "presser")


def _safety(reader: _Reader, node: Node) -> Safety:
    f = reader.mapping(node, "safety", ("deadman_timeout", "offline_after", "estop_reset"))

    def positive(n: Node, p: str) -> float:
        return reader.number(n, p, positive=True)

    return Safety(
        deadman_timeout=reader.get(f, "deadman_timeout", "safety", positive, 0.5),
        offline_after=reader.get(f, "offline_after", "safety", positive, 2.0),
        estop_reset=reader.get(
            f, "estop_reset", "safety", lambda n, p: reader.choice(n, p, ESTOP_RESETS), Safety.estop_reset
        ),
    )


#: A relay's id: as the other relays accept it in keys and samples (relay/backends/zenoh_keys.py's PEER_NAME).
_RELAY_ID = re.compile(r"^[\w.-]{1,64}$")
_RELAY_ID_TEXT = "a name of 1 to 64 letters, digits, _ . or -"
#: Relays heartbeat their leases every second; three may be late or lost before a live relay's lease lapses.
MIN_PEER_LEASE_TIMEOUT = 3.0
_KEY = re.compile(r"^[^*$#?@\s/]+(/[^*$#?@\s/]+)*$")


def _zenoh(reader: _Reader, node: Node) -> Zenoh:
    path = "zenoh"
    f = reader.mapping(
        node,
        path,
        ("connect", "mode", "config", "keys", "domain_id", "fleet_key", "relay_id", "peer_lease_timeout"),
    )
    connect: list[str] = []
    if "connect" in f:
        for i, n in reader.sequence(f["connect"], "zenoh.connect"):
            connect.append(reader.string(n, f"zenoh.connect[{i}]", expected="a Zenoh endpoint such as tcp/HOST:7447"))
    domain_id = None
    if "domain_id" in f:
        node_id = f["domain_id"]
        domain_id = reader.value(node_id) if isinstance(node_id, ScalarNode) else None
        if not isinstance(domain_id, int) or isinstance(domain_id, bool) or not 0 <= domain_id <= 232:
            raise reader.fail(node_id, "zenoh.domain_id", f"expected a ROS domain id 0-232, got {reader.show(node_id)}")
    peer_lease_timeout = Zenoh.peer_lease_timeout
    if "peer_lease_timeout" in f:
        node_timeout = f["peer_lease_timeout"]
        peer_lease_timeout = reader.number(node_timeout, "zenoh.peer_lease_timeout", positive=True)
        if peer_lease_timeout < MIN_PEER_LEASE_TIMEOUT:
            # Relays heartbeat every second: a shorter timeout would drop a live relay's lease on one late beat.
            raise reader.fail(
                node_timeout,
                "zenoh.peer_lease_timeout",
                f"expected at least {MIN_PEER_LEASE_TIMEOUT:g} s (relays heartbeat every second), "
                f"got {peer_lease_timeout:g}",
            )
    return Zenoh(
        connect=tuple(connect),
        mode=reader.get(f, "mode", path, lambda n, p: reader.choice(n, p, ZENOH_MODES), Zenoh.mode),
        config=reader.get(f, "config", path, lambda n, p: reader.string(n, p, expected="a Zenoh JSON5 file"), None),
        keys=reader.get(f, "keys", path, lambda n, p: reader.choice(n, p, ZENOH_KEYS), Zenoh.keys),
        domain_id=domain_id,
        fleet_key=reader.get(
            f, "fleet_key", path, lambda n, p: reader.string(n, p, pattern=_KEY, expected="a Zenoh key"), "xr_relay"
        ),
        relay_id=reader.get(
            f, "relay_id", path, lambda n, p: reader.string(n, p, pattern=_RELAY_ID, expected=_RELAY_ID_TEXT), None
        ),
        peer_lease_timeout=peer_lease_timeout,
    )


def _ros(reader: _Reader, node: Node, base_dir: Path | None) -> Ros:
    f = reader.mapping(node, "ros", ("map_topic", "heartbeat_topic", "qos", "executor", "dds_profile"))
    map_topic = Ros.map_topic
    if "map_topic" in f:
        map_topic = _topic(reader, f["map_topic"], "ros.map_topic", "")
    heartbeat_topic = Ros.heartbeat_topic
    if "heartbeat_topic" in f:
        heartbeat_topic = _topic(reader, f["heartbeat_topic"], "ros.heartbeat_topic", "")
    qos = dict(Ros.qos)
    if "qos" in f:
        q = reader.mapping(f["qos"], "ros.qos", QOS_NAMES)
        for key, value in q.items():
            qos[key] = reader.choice(value, f"ros.qos.{key}", ("reliable", "best_effort"))  # type: ignore[assignment]
    executor = Ros.executor
    if "executor" in f:
        executor = reader.choice(f["executor"], "ros.executor", ("events", "single"))
    dds_profile = Ros.dds_profile
    if "dds_profile" in f:
        dds_profile = reader.string(f["dds_profile"], "ros.dds_profile", expected="large_images, builtin or a path")
        if dds_profile not in ("large_images", "builtin"):
            path = Path(dds_profile)
            if base_dir is not None and not path.is_absolute():
                path = base_dir / path
            if not path.is_file():
                raise reader.fail(f["dds_profile"], "ros.dds_profile", f"no Fast DDS profile file at {path}")
            dds_profile = str(path)
    return Ros(
        map_topic=map_topic,
        heartbeat_topic=heartbeat_topic,
        qos=tuple(qos.items()),
        executor=executor,
        dds_profile=dds_profile,
    )
