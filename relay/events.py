"""Typed events that backends hand to the relay, always on the event loop thread.

They are immutable snapshots: a ROS callback builds one on its executor thread and it crosses to the loop
as is (see ``relay.backends.ros``), so nothing mutable is shared between threads.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal


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
class FrameEvent:
    """An encoded camera image (JPEG) for one robot camera."""

    robot: str
    camera: str
    stamp: float
    width: int
    height: int
    jpeg: bytes


Event = PoseEvent | SensorEvent | NavEvent | FrameEvent
EventSink = Callable[[Event], None]
