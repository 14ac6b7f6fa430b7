"""What ``hello`` tells a client about the station: its robots (cameras, sensors, limits), scene, rooms and
vantage point, and the shapes other messages reuse (a 2D transform, a goal)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import NotRequired, Protocol, TypedDict


class Lens(TypedDict):
    model: str  # equidistant | equisolid | stereographic | pinhole | opencv_fisheye
    fov: float  # degrees, full field of view across the image circle / width
    K: NotRequired[list[float]]  # 3x3 row-major, opencv_fisheye only
    D: NotRequired[list[float]]  # k1..k4, opencv_fisheye only


class CameraDescription(TypedDict):
    name: str
    identifier: str  # identifier of its binary frames, e.g. "robot1/camera/front"
    lens: Lens
    width: int
    height: int
    codecs: list[str]  # what ``<robot>/stream`` may ask for: "jpeg", and "h264" when the size allows it
    on_arm: bool  # it rides on the robot's arm (robots.yaml ``arm.camera``): its view moves with the gripper


class SensorDescription(TypedDict):
    name: str
    unit: str
    warn_above: float | None
    warn_below: float | None


class Limits(TypedDict):
    linear: float
    angular: float


class RobotDescription(TypedDict):
    name: str
    colour: str
    model: str
    cameras: list[CameraDescription]
    sensors: list[SensorDescription]
    limits: Limits
    team: str | None  # robots.yaml's team, None: in none


class Transform2D(TypedDict):
    x: float
    y: float
    z: float
    yaw: float


class SceneDescription(TypedDict):
    url: str | None
    map_to_scene: Transform2D


class RoomDescription(TypedDict):
    name: str
    title: str
    bounds: list[float]


class VantageDescription(TypedDict):
    x: float
    y: float
    yaw: float


class GoalDescription(TypedDict):
    x: float
    y: float
    yaw: float | None


class Room(Protocol):
    """A room of a scene file, as far as ``hello`` describes it (relay/sim/floorplan.py has them)."""

    @property
    def name(self) -> str: ...
    @property
    def title(self) -> str: ...
    @property
    def min_x(self) -> float: ...
    @property
    def min_y(self) -> float: ...
    @property
    def max_x(self) -> float: ...
    @property
    def max_y(self) -> float: ...


def room_descriptions(rooms: Iterable[Room]) -> list[RoomDescription]:
    """The rooms of a scene file as ``hello.rooms`` names them."""
    return [{"name": r.name, "title": r.title, "bounds": [r.min_x, r.min_y, r.max_x, r.max_y]} for r in rooms]
