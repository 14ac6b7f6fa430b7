"""Typed events that backends hand to the relay, always on the event loop thread.

They are immutable snapshots: a ROS callback builds one on its executor thread and it crosses to the loop
as is (see ``relay.backends.ros``), so nothing mutable is shared between threads.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from .occupancy import OccupancyGrid


@dataclass(frozen=True, slots=True)
class PoseEvent:
    robot: str
    stamp: float  # seconds since the epoch (ROS time of the source message)
    frame: str
    x: float
    y: float
    z: float
    qx: float
    qy: float
    qz: float
    qw: float


@dataclass(frozen=True, slots=True)
class SensorEvent:
    robot: str
    name: str
    value: float
    stamp: float


Goal = tuple[float, float, float | None]  # x, y, yaw (yaw may be None)
GateWord = Literal["drive", "hold", "estop"]


@dataclass(frozen=True, slots=True)
class NavEvent:
    """Navigation changed: a goal started, was reached, failed or was cancelled."""

    robot: str
    navigating: bool
    goal: Goal | None
    outcome: Literal["started", "reached", "failed", "cancelled"]
    message: str = ""
    #: Nav2's error code of a failed goal (its GetResult's ``error_code``), when the backend could ask.
    error_code: int | None = None


@dataclass(frozen=True, slots=True)
class NavFeedbackEvent:
    """Nav2's feedback on the goal the robot follows: metres and seconds to go, recoveries so far, time spent."""

    robot: str
    goal: Goal
    distance_remaining: float
    eta: float
    recoveries: int
    navigation_time: float


@dataclass(frozen=True, slots=True)
class CancelAnswerEvent:
    """What the navigator answered to a cancel the relay sent for ``goal``: ``confirmed`` is False when it did not
    answer in time (or refused while the goal still ran); ``message`` says which. Changes no state: the goal was
    reported cancelled when the relay gave it up."""

    robot: str
    goal: Goal | None
    confirmed: bool
    message: str


@dataclass(frozen=True, slots=True)
class GateStateEvent:
    """The robot's watchdog reported its gate (``drive``, ``hold`` or ``estop``): a latch the relay must show."""

    robot: str
    word: GateWord


@dataclass(frozen=True, slots=True)
class PathEvent:
    """The robot's planned path to its goal (map frame, metres), as its planner made it; empty: no plan now."""

    robot: str
    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True, slots=True)
class FrameEvent:
    """An encoded camera image (JPEG) for one robot camera; ``pixels``: the BGR image it was encoded from, when the
    backend had one (the H.264 encoder takes it rather than decoding the JPEG again)."""

    robot: str
    camera: str
    stamp: float
    width: int
    height: int
    jpeg: bytes
    pixels: Any = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class CameraError:
    """A streamed camera's images cannot be read (an encoding the relay does not know, a size that does not match
    the bytes): its viewers are told, and their streams end."""

    robot: str
    camera: str
    message: str


@dataclass(frozen=True, slots=True)
class ScanEvent:
    """A laser scan, already decimated, in the robot's scan frame (ranges in metres, NaN = no return)."""

    robot: str
    stamp: float
    frame: str
    angle_min: float
    angle_increment: float
    range_max: float
    ranges: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class CloudEvent:
    """A robot's point cloud (issue #33): ``points`` (N, 3) float32 in the sensor's frame, ``pose`` (4x4) that frame
    in the map at ``stamp``, ``rgb`` (N, 3) uint8 or None. Arrays the backend no longer touches."""

    robot: str
    stamp: float
    points: Any = field(compare=False, repr=False)
    pose: Any = field(compare=False, repr=False)
    rgb: Any = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, slots=True)
class MapEvent:
    """A new occupancy grid of the fleet's map (fleet-wide: ``robot`` is empty).

    ``grid`` counts unknown cells as occupied (what a planner must avoid); ``unknown`` marks them, so that
    a twin can draw them as floor rather than walls.
    """

    grid: OccupancyGrid
    stamp: float
    robot: str = ""
    unknown: NDArray[np.bool_] | None = None


@dataclass(frozen=True, slots=True)
class RobotModelEvent:
    """A robot's URDF (its robot_description), for the relay to turn into its twin model."""

    robot: str
    urdf: str


@dataclass(frozen=True, slots=True)
class PlaybackEvent:
    """Where a replayed recording is (fleet-wide: ``robot`` is empty)."""

    position: float
    duration: float
    rate: float
    paused: bool
    loop: bool
    robot: str = ""


@dataclass(frozen=True, slots=True)
class JointStateEvent:
    """An arm's joints as sensor_msgs/JointState carries them (the chain's, the gripper's and its mimics'): rad or m,
    and rad/s or m/s (empty when the source gives none)."""

    robot: str
    stamp: float
    names: tuple[str, ...]
    positions: tuple[float, ...]
    velocities: tuple[float, ...] = ()


@dataclass(frozen=True, slots=True)
class AvatarEvent:
    """Where an operator looked from (a replayed session's ``viewer`` frames, relay/wire/viewer.py): the head's position
    and facing, each hand's position and ray (map frame), at ``stamp``; fleet-wide (``robot`` is empty)."""

    client: str
    name: str | None
    stamp: float
    head: tuple[tuple[float, float, float], tuple[float, float, float]]
    hands: tuple[tuple[Literal["left", "right"], tuple[float, float, float], tuple[float, float, float]], ...]


@dataclass(frozen=True, slots=True)
class ValveEvent:
    """The simulated facility's valve wheel (robots.yaml ``sim.valve``; fleet-wide: ``robot`` is empty): its centre
    (map frame, m), axis (rad) and rim (m), how far it has been turned (rad), whether a gripper holds it and whether
    it is shut."""

    x: float
    y: float
    z: float
    yaw: float
    radius: float
    angle: float
    held: bool
    shut: bool
    robot: str = ""


Event = (
    PoseEvent
    | SensorEvent
    | NavEvent
    | NavFeedbackEvent
    | CancelAnswerEvent
    | GateStateEvent
    | PathEvent
    | FrameEvent
    | CameraError
    | ScanEvent
    | CloudEvent
    | MapEvent
    | PlaybackEvent
    | RobotModelEvent
    | JointStateEvent
    | AvatarEvent
    | ValveEvent
)
EventSink = Callable[[Event], None]
