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


@dataclass(frozen=True, slots=True)
class NavEvent:
    """Navigation changed: a goal started, was reached, failed or was cancelled."""

    robot: str
    navigating: bool
    goal: tuple[float, float, float | None] | None  # x, y, yaw (yaw may be None)
    outcome: Literal["started", "reached", "failed", "cancelled"]
    message: str = ""


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


Event = (
    PoseEvent
    | SensorEvent
    | NavEvent
    | PathEvent
    | FrameEvent
    | CameraError
    | ScanEvent
    | MapEvent
    | PlaybackEvent
    | RobotModelEvent
)
EventSink = Callable[[Event], None]
