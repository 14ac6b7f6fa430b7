"""The robots' own clouds (robots.yaml ``clouds:``, issue #33) taken in by the ``ros``, ``zenoh`` and ``bag`` backends:
read off the event loop, bounded, placed in the map at their stamps, and handed on as the sim's depth cameras' are
(:class:`~relay.fleet.events.CloudEvent`, fused by relay/mapping/fusion.py).

**Bounded.** Each source is read at most its ``rate`` times a second (a cloud over it is dropped unread, counted
``capped``), and one waits per source: a cloud arriving while the previous one waits for the decoding thread
replaces it (counted ``replaced``). One thread of its own decodes, one cloud after the other: a PointCloud2 through a
structured dtype (relay/cloud/pointcloud2.py), a depth image through its CameraInfo's pinhole (relay/cloud/depth.py),
never a loop per point, never on the loop nor on the thread that receives (which must keep draining the network).

**Placed** by relay/cloud/placement.py: the robot's poses (every pose event the backend sees, fed here from its
receiving threads) at the cloud's stamp, and the sensor's frame on the robot from robots.yaml's ``mount`` or
/tf_static. A cloud newer than the robot's newest pose waits for one, up to :data:`POSE_PATIENCE` (one a source; a
newer cloud replaces it), as tf2's message filter does.

**What cannot be used is named**: a layout that is not what it says, a cloud of NaNs only, an unknown depth encoding,
no CameraInfo yet, no transform at the stamp: a warning naming the robot, the cloud, its topic and why (one per
source every :data:`LOG_EVERY` seconds), and ``/healthz``'s ``clouds`` entry of that source (``failed``,
``last_error``). Points that are NaN or infinite (an organized cloud's missing returns) are dropped and counted
(``non_finite``), named once in the log. Nothing is raised to the backend.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from functools import partial
from typing import Any, Final, TypeVar

import numpy as np

from ..cloud.depth import image_points
from ..cloud.errors import CloudError
from ..cloud.placement import NotYet, Placement, matrix, rpy_matrix
from ..cloud.pointcloud2 import decode_pointcloud2
from ..config import CloudSource, FleetConfig, Robot
from ..fleet.events import CloudEvent, PoseEvent
from ..fleet.scan import RateCap
from ..ros.rosmsg import header_stamp

logger = logging.getLogger(__name__)

POINTCLOUD2: Final = "sensor_msgs/msg/PointCloud2"
IMAGE: Final = "sensor_msgs/msg/Image"
CAMERA_INFO: Final = "sensor_msgs/msg/CameraInfo"
TF_MESSAGE: Final = "tf2_msgs/msg/TFMessage"
#: Seconds between two warnings about one source's clouds (each failure is counted in /healthz all the same).
LOG_EVERY: Final = 10.0
#: Seconds a decoded cloud newer than its robot's newest pose waits for one (poses and clouds travel apart: a cloud
#: sent just before the odometry of its instant is read first), as tf2's message filter waits; and how often it looks.
POSE_PATIENCE: Final = 1.0
PLACE_POLL: Final = 0.05

Decode = Callable[[bytes, str], Any]
Key = tuple[str, str]  # robot, cloud name
T = TypeVar("T")


def cloud_intake(
    config: FleetConfig, emit: Callable[[CloudEvent], None], decode: Decode | None = None
) -> CloudIntake | None:
    """The intake of the fleet's cloud sources, started; None when there are none, or no 3D map to feed (robots.yaml
    without ``cloud``: said once in the log)."""
    robots = [robot.name for robot in config.robots if robot.clouds]
    if not robots:
        return None
    if config.cloud is None:
        logger.warning(
            "%s gives clouds to %s but has no `cloud` section: there is no 3D map, and they are not read",
            config.source, ", ".join(robots),
        )  # fmt: skip
        return None
    intake = CloudIntake(config.robots, emit, decode)
    intake.start()
    return intake


def message_type(source: CloudSource) -> str:
    return POINTCLOUD2 if source.kind == "pointcloud2" else IMAGE


def static_topic(robot: Robot) -> str | None:
    """The /tf_static a robot's clouds are placed through: its TF's, else its namespace's; None when every cloud has a
    mount."""
    if all(source.mount is not None for source in robot.clouds):
        return None
    return robot.pose.topic + "_static" if robot.pose.source == "tf" else f"{robot.namespace.rstrip('/')}/tf_static"


def cloud_topics(robot: Robot, intake: CloudIntake, decode: Decode) -> list[tuple[str, str, Callable[[bytes], None]]]:
    """``(topic, type, raw callback)`` of each subscription a live backend makes for a robot's clouds: the clouds, a
    depth image's CameraInfo, and /tf_static when a cloud has no mount (any thread calls them)."""
    name = robot.name
    out: list[tuple[str, str, Callable[[bytes], None]]] = []
    for source in robot.clouds:
        out.append((source.topic, message_type(source), partial(intake.offer, name, source.name)))
        if source.camera_info is not None:
            out.append((source.camera_info, CAMERA_INFO, partial(intake.camera_info, name, source.name)))
    static = static_topic(robot)
    if static is not None:
        warned: list[bool] = []  # once: anyone on a Zenoh network can send bytes that are not the message

        def on_static(data: bytes) -> None:
            try:
                intake.transforms(name, decode(data, TF_MESSAGE))
            except ValueError as exc:
                if not warned:
                    warned.append(True)
                    logger.warning("%s: %s for its clouds: %s (said once)", name, static, exc)

        out.append((static, TF_MESSAGE, on_static))
    return out


@dataclass
class SourceHealth:
    """One source's counts since start (/healthz ``clouds``)."""

    topic: str
    received: int = 0
    capped: int = 0  # over its rate: not read
    replaced: int = 0  # a newer one came while it waited
    decoded: int = 0  # handed to the map
    failed: int = 0
    non_finite: int = 0  # points dropped as NaN or infinite
    last_error: str | None = None


@dataclass(frozen=True, slots=True)
class _Decoded:
    """A cloud's points in its frame, waiting to be placed (its pose may come after it) until ``deadline``."""

    key: Key
    stamp: float
    frame: str
    xyz: Any
    rgb: Any
    deadline: float  # monotonic


@dataclass(frozen=True, slots=True)
class _Waiting:
    key: Key
    data: Any  # CDR bytes, or a message already decoded (a bag's)


class CloudIntake:
    """Every robot's cloud sources: their caps, the one waiting of each, the thread that decodes them.

    ``emit`` gets each CloudEvent on the decoding thread (the backend's crossing to the loop); ``decode`` turns CDR
    bytes into a message (rosbags, relay/backends/ingest.RawDecoder). Every other method may be called from any
    thread.
    """

    def __init__(
        self, robots: Sequence[Robot], emit: Callable[[CloudEvent], None], decode: Decode | None = None
    ) -> None:
        self._emit = emit
        self._decode = decode
        self._sources: dict[Key, CloudSource] = {}
        self._mounts: dict[Key, Any] = {}
        self._health: dict[Key, SourceHealth] = {}
        self._placement: dict[str, Placement] = {}
        for robot in robots:
            self._placement[robot.name] = Placement(robot.pose.map_frame, robot.pose.base_frame)
            for source in robot.clouds:
                key = (robot.name, source.name)
                self._sources[key] = source
                self._health[key] = SourceHealth(source.topic)
                m = source.mount
                self._mounts[key] = None if m is None else rpy_matrix(m.x, m.y, m.z, m.roll, m.pitch, m.yaw)
        self._caps = {key: RateCap(source.rate) for key, source in self._sources.items()}
        self._info: dict[Key, Any] = {}
        self._waiting: dict[Key, _Waiting] = {}
        self._unplaced: dict[Key, _Decoded] = {}  # the decoding thread's own
        self._logged: dict[Key, float] = {}
        self._cond = threading.Condition()
        self._stopped = False
        self._thread: threading.Thread | None = None

    def sources(self, robot: str) -> list[CloudSource]:
        return [s for (name, _), s in self._sources.items() if name == robot]

    # -- lifecycle --------------------------------------------------------------------------------

    def start(self) -> None:
        if self._thread is None and self._sources:
            self._thread = threading.Thread(target=self._run, name="cloud-intake", daemon=True)
            self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        with self._cond:
            self._stopped = True
            self._waiting.clear()
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join(timeout)

    def health(self) -> dict[str, object]:
        """``{"clouds": {"robot/cloud": counts}}`` for /healthz (none without sources)."""
        if not self._sources:
            return {}
        with self._cond:
            return {"clouds": {f"{r}/{n}": asdict(h) for (r, n), h in self._health.items()}}

    # -- what the backend feeds (any thread) ------------------------------------------------------

    def pose(self, event: PoseEvent) -> None:
        placement = self._placement.get(event.robot)
        if placement is not None:
            with self._cond:
                placement.poses.add(event.stamp, (event.x, event.y, event.z), (event.qx, event.qy, event.qz, event.qw))

    def forget_poses(self, robots: Sequence[str]) -> None:
        """A bag seeked: the poses read so far of its ``robots`` are of another time."""
        with self._cond:
            for robot in robots:
                if robot in self._placement:
                    self._placement[robot].poses.clear()

    def transforms(self, robot: str, message: Any) -> None:
        """A tf2_msgs/TFMessage of /tf_static (rosbags' or rclpy's)."""
        placement = self._placement.get(robot)
        if placement is None:
            return
        for t in message.transforms:
            tr, q = t.transform.translation, t.transform.rotation
            try:
                pose = matrix((tr.x, tr.y, tr.z), (q.x, q.y, q.z, q.w))
            except CloudError:
                continue
            with self._cond:
                placement.statics.add(str(t.header.frame_id), str(t.child_frame_id), pose)

    def camera_info(self, robot: str, name: str, data: Any) -> None:
        """A depth source's sensor_msgs/CameraInfo (bytes, or a message); its latest is used."""
        key = (robot, name)
        try:
            message = self._decode(data, CAMERA_INFO) if isinstance(data, bytes) and self._decode else data
        except ValueError as exc:
            self._failed(key, f"camera_info {self._sources[key].camera_info}: {exc}")
            return
        with self._cond:
            self._info[key] = message

    def offer(self, robot: str, name: str, data: Any, now: float | None = None) -> None:
        """A cloud (CDR bytes, or a message): decoded when the thread gets to it, unless over its rate at ``now``
        (monotonic seconds; None: the clock's)."""
        key = (robot, name)
        if key not in self._sources:
            return
        with self._cond:
            health = self._health[key]
            health.received += 1
            if not self._caps[key].allow(f"{robot}/{name}", time.monotonic() if now is None else now):
                health.capped += 1
                return
            if key in self._waiting:
                health.replaced += 1
                del self._waiting[key]  # the newer one goes to the back: sources take turns
            self._waiting[key] = _Waiting(key, data)
            self._cond.notify()

    # -- the decoding thread ----------------------------------------------------------------------

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._waiting and not self._stopped:
                    if self._unplaced:  # a cloud waits for its robot's pose: look again soon
                        self._cond.wait(PLACE_POLL)
                        break
                    self._cond.wait()
                if self._stopped:
                    return
                item = self._waiting.pop(next(iter(self._waiting))) if self._waiting else None
            if item is not None:
                decoded = self._guarded(item.key, partial(self._decoded, item.key, item.data))
                if decoded is not None:
                    if item.key in self._unplaced:  # an older one still waits for its pose: this one replaces it
                        with self._cond:
                            self._health[item.key].replaced += 1
                    self._unplaced[item.key] = decoded
            for key, cloud in list(self._unplaced.items()):
                self._place(key, cloud)

    def _place(self, key: Key, cloud: _Decoded) -> None:
        """Emit ``cloud`` placed at its stamp, or keep it until its pose comes (or its deadline: then it failed)."""
        try:
            event = self._guarded(key, partial(self._placed, cloud), waiting=time.monotonic() < cloud.deadline)
        except NotYet:
            return
        del self._unplaced[key]
        if event is not None:
            with self._cond:
                self._health[key].decoded += 1
            self._emit(event)

    def _guarded(self, key: Key, work: Callable[[], T], *, waiting: bool = False) -> T | None:
        """``work()``, or None after its failure is counted and named (NotYet raised while ``waiting``)."""
        try:
            return work()
        except NotYet as exc:
            if waiting:
                raise
            error = str(exc)
        except (CloudError, ValueError) as exc:
            error = str(exc)
        except Exception as exc:  # a decoder's bug must not end the thread: the next cloud is read
            logger.exception("%s/%s: cloud not read", *key)
            error = f"{type(exc).__name__}: {exc}"
        self._failed(key, error)
        return None

    def _decoded(self, key: Key, data: Any) -> _Decoded:
        robot, name = key
        source = self._sources[key]
        if isinstance(data, bytes):
            if self._decode is None:
                raise CloudError("no decoder for raw messages")
            data = self._decode(data, message_type(source))
        rgb = None
        if source.kind == "pointcloud2":
            cloud = decode_pointcloud2(data)
            xyz, rgb = cloud.xyz, cloud.rgb
            total = int(data.width) * int(data.height)
        else:
            with self._cond:
                info = self._info.get(key)
            if info is None:
                raise CloudError(f"no CameraInfo on {source.camera_info} yet")
            xyz = image_points(data, info, source.stride).xyz
            total = len(xyz)  # a depth image's 0 or NaN is "no return" (REP 118), not a bad point
        dropped = total - len(xyz)
        if total and not len(xyz):
            raise CloudError(f"all {total} points are NaN or infinite")
        with self._cond:
            health = self._health[key]
            first = dropped > 0 and health.non_finite == 0
            health.non_finite += dropped
        if first:
            logger.warning(
                "%s cloud %s on %s: %d of %d points are NaN or infinite; they are dropped (counted in /healthz)",
                robot, name, source.topic, dropped, total,
            )  # fmt: skip
        stamp = header_stamp(data.header)
        return _Decoded(key, stamp, str(data.header.frame_id), xyz, rgb, time.monotonic() + POSE_PATIENCE)

    def _placed(self, cloud: _Decoded) -> CloudEvent:
        robot = cloud.key[0]
        with self._cond:
            pose = self._placement[robot].sensor(cloud.frame, cloud.stamp, self._mounts[cloud.key])
        if not np.isfinite(pose).all() or not math.isfinite(cloud.stamp):
            raise CloudError(f"a pose at stamp {cloud.stamp} that is not finite")
        return CloudEvent(robot, cloud.stamp, cloud.xyz, pose, cloud.rgb)

    def _failed(self, key: Key, why: str) -> None:
        robot, name = key
        now = time.monotonic()
        with self._cond:
            health = self._health[key]
            health.failed += 1
            health.last_error = why
            due = now - self._logged.get(key, -math.inf) >= LOG_EVERY
            if due:
                self._logged[key] = now
        if due:
            logger.warning("%s cloud %s on %s not used: %s", robot, name, self._sources[key].topic, why)
