"""The fleet configuration as the relay uses it: frozen dataclasses read from robots.yaml (relay.config)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

PoseSourceKind = Literal["tf", "odom", "amcl_pose", "pose"]
NavInterface = Literal["nav2", "topic"]
NAV_INTERFACES: tuple[NavInterface, ...] = ("nav2", "topic")
POSE_SOURCES: tuple[PoseSourceKind, ...] = ("tf", "odom", "amcl_pose", "pose")
RelayLost = Literal["hold", "continue"]
ON_RELAY_LOST: tuple[RelayLost, ...] = ("hold", "continue")
LENS_MODELS = ("equidistant", "equisolid", "stereographic", "pinhole", "opencv_fisheye")


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
    #: H.264 target bits per second (None: relay.media.video.default_bitrate, 2.5 Mbit/s at 720p30, scaled by pixels)
    bitrate: int | None = None


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
class Workspace:
    """The box the arm's tip must stay in, in the arm's base link frame (metres)."""

    min: tuple[float, float, float]
    max: tuple[float, float, float]

    def contains(self, x: float, y: float, z: float) -> bool:
        return all(lo <= v <= hi for lo, v, hi in zip(self.min, (x, y, z), self.max, strict=True))


@dataclass(frozen=True)
class ArmTopics:
    """Where the arm's state comes from and its commands go (absolute), as MoveIt Servo and ros2_control name them."""

    joint_states: str  # sensor_msgs/JointState (joint_state_broadcaster)
    delta_twist_cmds: str  # geometry_msgs/TwistStamped into MoveIt Servo
    joint_trajectory: str  # trajectory_msgs/JointTrajectory of the arm's controller (named poses)
    gripper_cmd: str  # control_msgs/action/GripperCommand of the gripper's controller


@dataclass(frozen=True)
class Arm:
    """An arm on the robot (robots.yaml ``arm:``; docs/configuration.md, "Arms")."""

    urdf: Path | None  # None: the robot's robot_description parameter
    base_link: str
    tip_link: str
    gripper_joint: str | None
    topics: ArmTopics
    limits: Limits  # the tip's speeds, clamped in the relay before a twist reaches MoveIt Servo (relay.arm.rules)
    workspace: Workspace
    #: A joint may not move closer than this to its limit (rad or m); MoveIt Servo's joint_limit_margin.
    joint_margin: float = 0.1
    camera: str | None = None  # the name of the robot's camera on the arm, if one is
    srdf: Path | None = None  # MoveIt's SRDF: the named poses (home, the gripper's open and close)
    #: The URDF and SRDF may be absent: the robot then runs without its arm (relay/arm/fleet_arms.py says why).
    optional: bool = False


CloudKind = Literal["pointcloud2", "depth"]
CLOUD_KINDS: tuple[CloudKind, ...] = ("pointcloud2", "depth")


@dataclass(frozen=True)
class Mount:
    """Where a sensor's frame sits on the robot: its pose in the robot's base frame (m, rad; roll, pitch, yaw about
    the base's x, y, z in that order, as URDF's ``rpy``)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class CloudSource:
    """A robot's source of 3D points for the live map (robots.yaml ``clouds:``; relay/config/clouds.py): a
    sensor_msgs/PointCloud2 topic, or a depth image (16UC1 mm, 32FC1 m) with its CameraInfo."""

    name: str
    kind: CloudKind
    topic: str  # absolute
    camera_info: str | None = None  # absolute; depth only
    #: The sensor's frame on the robot; None: from TF (the message's frame through /tf_static to the base frame).
    mount: Mount | None = None
    rate: float = 2.0  # Hz: the most clouds of this source decoded a second (the others are not even read)
    stride: int = 1  # depth: every n-th pixel of every n-th row


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
    plan_topic: str | None = None  # nav_msgs/Path of the robot's planner; None: none
    model_source: ModelSource | None = None
    #: Where the relay publishes its teleop (TwistStamped) for ``xr-relay watchdog``, which forwards fresh commands
    #: to ``cmd_vel_topic`` and stops the robot when they or the relay's heartbeat stop. None: straight to cmd_vel.
    watchdog_topic: str | None = None
    #: How goals reach the robot's navigation: ``nav2`` (Nav2's NavigateToPose action, named ``nav_action``) or
    #: ``topic`` (a bare PoseStamped on ``goal_topic``, the outcome guessed from the pose).
    nav_interface: NavInterface = "nav2"
    #: The NavigateToPose action (absolute; "" here means the default, ``<namespace>/navigate_to_pose``).
    nav_action: str = ""
    #: The robot's own velocity output that the watchdog gates (absolute; "" means ``<namespace>/cmd_vel_nav``,
    #: Nav2's controller remapped away from cmd_vel: docs/reliability.md).
    autonomy_topic: str = ""
    #: What the watchdog does with autonomy when the relay's heartbeat stops: ``hold`` it or let it ``continue``
    #: (teleop stops either way).
    on_relay_lost: RelayLost = "hold"
    arm: Arm | None = None  # an arm on the robot, moved by the operator's hand
    #: The team the robot works in (robots.yaml ``team``): the page groups robots by it, and by room, for commands
    #: and missions. None: in no team.
    team: str | None = None
    #: Its point clouds and depth images for the live 3D map (issue #33; used with robots.yaml's ``cloud``).
    clouds: tuple[CloudSource, ...] = ()

    def __post_init__(self) -> None:
        # Frozen: the namespace's defaults are filled in once, here, for entries built without them.
        if not self.nav_action:
            object.__setattr__(self, "nav_action", f"{self.namespace.rstrip('/')}/navigate_to_pose")
        if not self.autonomy_topic:
            object.__setattr__(self, "autonomy_topic", f"{self.namespace.rstrip('/')}/cmd_vel_nav")

    @property
    def gate_topic(self) -> str:
        """std_msgs/String ``drive``, ``hold`` or ``estop`` from the relay to the watchdog (transient local)."""
        return f"{self.namespace.rstrip('/')}/xr_relay/gate"

    @property
    def gate_state_topic(self) -> str:
        """std_msgs/String: the watchdog's gate now (transient local), from which a new relay learns a latch."""
        return f"{self.namespace.rstrip('/')}/xr_relay/gate_state"

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
class SpillGrowth:
    """How the simulated chemical spill grows (relay/sim/spill.py): its radii gain ``rate`` times their first
    size each minute of simulated time, up to ``limit`` times it. ``rate`` 0 (the default): it never grows."""

    rate: float = 0.0  # per minute, >= 0
    limit: float = 2.0  # >= 1

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate) and self.rate >= 0.0):
            raise ValueError(f"rate must be a number >= 0, got {self.rate!r}")
        if not (math.isfinite(self.limit) and self.limit >= 1.0):
            raise ValueError(f"limit must be a number >= 1, got {self.limit!r}")

    def scale(self, elapsed: float) -> float:
        """The spill's size after ``elapsed`` seconds, as a multiple of its first: 1 at 0 (and before),
        growing linearly, never above ``limit``; non-decreasing in ``elapsed``."""
        if not elapsed > 0.0 or self.rate == 0.0:  # NaN: a clock that has not started; 0 x inf would be NaN
            return 1.0
        return min(self.limit, 1.0 + self.rate * elapsed / 60.0)


@dataclass(frozen=True)
class Sim:
    world: Path | None = None  # a facility.yaml (scene tool output): occupancy grid and hazard sources
    physics_rate: float = 50.0
    pose_rate: float = 30.0
    sensor_rate: float = 5.0
    scan_rate: float = 5.0  # Hz, for robots with a `scan` (at most protocol.MAX_SCAN_RATE)
    hazards: tuple[Hazard, ...] = ()
    fields: tuple[Field, ...] = ()
    spill_growth: SpillGrowth = field(default_factory=SpillGrowth)
    valve: Valve | None = None  # a valve wheel an arm turns to shut a leak (issue #32)


@dataclass(frozen=True)
class Valve:
    """A valve wheel of the simulated facility, turned by a gripper (robots.yaml ``sim.valve``; relay/sim/valve.py)."""

    x: float  # the wheel's centre, map frame (m)
    y: float
    z: float
    hazard: str  # the sensor field whose nearby sources it shuts
    yaw: float = 0.0  # rad: its axis (the way its face looks), horizontal
    radius: float = 0.05  # m, its rim
    fade: float = 8.0  # s: once shut, the leak's reading falls to e^-1 of its excess in this time


@dataclass(frozen=True)
class Cloud:
    """robots.yaml's ``cloud``: the live 3D map fused from the robots' clouds (issue #33; relay/config/cloud.py)."""

    voxel: float = 0.05  # m, a voxel's side
    budget_blocks: int = 20_000  # blocks of 16^3 voxels kept at most (least recently seen dropped first)
    save_every: float = 60.0  # s between saves of the map beside the database (and once at shutdown)
    sim_depth_rate: float = 2.0  # Hz, each simulated robot's depth camera (0: none)


@dataclass(frozen=True)
class Safety:
    deadman_timeout: float = 0.5
    offline_after: float = 2.0
    #: Who may reset an E-STOP: "anyone" whose role may reset (relay/accounts/roles.py), or "presser": only who
    #: pressed it, and admins (a site where the one who stopped the fleet must agree it moves again).
    estop_reset: str = "anyone"


QOS_NAMES = ("pose", "sensors", "scan", "images", "commands", "map")
Reliability = Literal["reliable", "best_effort"]


@dataclass(frozen=True)
class Ros:
    """Settings of the ``ros`` backend."""

    map_topic: str = "/map"
    #: std_msgs/Header the relay publishes from its event loop (10 Hz) while it runs; ``xr-relay watchdog`` stops
    #: its robots when it stops.
    heartbeat_topic: str = "/xr_relay/heartbeat"
    #: rclpy executor: "events" (the EventsExecutor, 3.5x the other's raw ingest) or "single" (the
    #: SingleThreadedExecutor, for an rclpy without a working EventsExecutor). relay/backends/ros_spinner.py.
    executor: str = "events"
    #: Fast DDS participant profile: "large_images" (relay/backends/fastdds_large_images.xml: raw 720p images
    #: through shared memory), "builtin" (Fast DDS's own transports) or a profile file's path. An environment that
    #: sets FASTDDS_DEFAULT_PROFILES_FILE wins. relay/backends/dds_profile.py.
    dds_profile: str = "large_images"
    #: Reliability per kind of topic; depth and durability are fixed (images depth 1, map transient local).
    qos: tuple[tuple[str, Reliability], ...] = (
        ("pose", "best_effort"),
        ("sensors", "best_effort"),
        ("scan", "best_effort"),
        # Reliable, depth 10: best effort loses most large images whose fragments drop (0.6 of 30 fps for
        # 640x480 rgb8 vs 30 fps reliable, bench/bench_camera.py); depth 10 still bounds the queue.
        ("images", "reliable"),
        ("commands", "reliable"),
        ("map", "reliable"),
    )

    def reliability(self, kind: str) -> Reliability:
        return dict(self.qos)[kind]


ZENOH_MODES = ("client", "peer")
ZENOH_KEYS = ("rmw_zenoh", "bridge")


@dataclass(frozen=True)
class Zenoh:
    """Settings of the ``zenoh`` backend (docs/zenoh.md); ``--zenoh-*`` on the command line override them."""

    #: Zenoh endpoints to connect to (``tcp/HOST:7447``); empty: the local router, tcp/127.0.0.1:7447.
    connect: tuple[str, ...] = ()
    #: ``client`` (through a router: one link to watch) or ``peer``.
    mode: str = "client"
    #: A Zenoh JSON5 configuration file (TLS, user/password, ...), read first; the settings above go on top.
    config: str | None = None
    #: ``rmw_zenoh`` (``<domain>/<topic>/<type>/<hash>``) or ``bridge`` (zenoh-bridge-ros2dds: ``<topic>``).
    keys: str = "rmw_zenoh"
    #: The ROS domain of rmw_zenoh's keys; None: $ROS_DOMAIN_ID, else 0.
    domain_id: int | None = None
    #: Where relays of one fleet share estops and leases: ``<fleet_key>/estop``, ``<fleet_key>/lease/...``.
    fleet_key: str = "xr_relay"
    #: This relay's name among the others; None: its Zenoh session id.
    relay_id: str | None = None
    #: Seconds a lease held through another relay lasts after that relay's last heartbeat (one a second).
    peer_lease_timeout: float = 10.0


@dataclass(frozen=True)
class Webhook:
    """An endpoint alerts are POSTed to, signed with ``secret`` (relay.inspection.webhooks)."""

    url: str  # http:// or https://
    secret: str = field(repr=False)  # never in a repr, a log line or the database
    #: Alert kinds (relay.inspection.records.ALERT_KINDS) and ``alert.acknowledged`` it wants; None: everything.
    events: tuple[str, ...] | None = None


@dataclass(frozen=True)
class InspectionSettings:
    #: Targets a site may hold, however they are made (operators, mission files, the scene): each is sent to every
    #: client that connects, so the count is bounded (an estop once waited 9.7 s behind ~2300 targets re-sent).
    max_targets: int = 2000
    webhooks: tuple[Webhook, ...] = ()


@dataclass(frozen=True)
class Site:
    """What the inspection report calls the site and whose clock it reads (docs/configuration.md, ``site``)."""

    #: Shown at the top of every report; None: the scene file's name.
    name: str | None = None
    #: An IANA time zone (``Europe/Berlin``) for the report's times; None: the relay's local zone (``TZ``).
    time_zone: str | None = None


@dataclass(frozen=True)
class FleetConfig:
    source: str
    robots: tuple[Robot, ...]
    scene: Scene = field(default_factory=lambda: Scene(None, MapToScene()))
    map: Path | None = None
    sim: Sim = field(default_factory=Sim)
    safety: Safety = field(default_factory=Safety)
    ros: Ros = field(default_factory=Ros)
    zenoh: Zenoh = field(default_factory=Zenoh)
    #: Where the map frame is on Earth (relay.inspection.kml.Georeference), for KML/KMZ placemarks; None: unknown.
    georeference: Any = None
    inspection: InspectionSettings = field(default_factory=InspectionSettings)
    site: Site = field(default_factory=Site)
    #: The live 3D map (issue #33); None: no fusion, no streaming, no simulated depth cameras.
    cloud: Cloud | None = None

    def robot(self, name: str) -> Robot | None:
        return next((r for r in self.robots if r.name == name), None)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.robots)
