"""The latest known state of every robot: what ``hello`` carries and what ``<robot>/status`` reports.

Pure bookkeeping with the clock passed in; the relay core feeds it events and reads messages back.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..config import FleetConfig, Robot
from ..session.protocol import Mode
from ..station.messages import (
    GoalDescription,
    PoseMessage,
    RobotState,
    SensorMessage,
    StatusMessage,
    pose_message,
    sensor_message,
    status_message,
)
from .events import NavEvent, PoseEvent, SensorEvent


@dataclass
class _RobotRecord:
    spec: Robot
    pose: PoseMessage | None = None
    sensors: dict[str, SensorMessage] = field(default_factory=dict)
    last_data: float | None = None  # monotonic time of the last pose
    navigating: bool = False
    goal: GoalDescription | None = None
    teleop: bool = False
    controller: str | None = None
    estopped: bool = False


class FleetState:
    def __init__(self, config: FleetConfig, offline_after: float) -> None:
        self._robots = {r.name: _RobotRecord(r) for r in config.robots}
        self.offline_after = offline_after

    def on_pose(self, event: PoseEvent, now: float) -> PoseMessage:
        record = self._robots[event.robot]
        record.last_data = now
        record.pose = pose_message(
            event.robot,
            stamp=event.stamp,
            frame=event.frame,
            x=event.x,
            y=event.y,
            z=event.z,
            qx=event.qx,
            qy=event.qy,
            qz=event.qz,
            qw=event.qw,
        )
        return record.pose

    def on_sensor(self, event: SensorEvent) -> SensorMessage | None:
        record = self._robots[event.robot]
        sensor = next((s for s in record.spec.sensors if s.name == event.name), None)
        if sensor is None:
            return None
        message = sensor_message(
            event.robot,
            name=event.name,
            value=event.value,
            unit=sensor.unit,
            warning=sensor.is_warning(event.value),
            stamp=event.stamp,
        )
        record.sensors[event.name] = message
        return message

    def on_nav(self, event: NavEvent) -> None:
        record = self._robots[event.robot]
        record.navigating = event.navigating
        if event.navigating and event.goal is not None:
            x, y, yaw = event.goal
            record.goal = {"x": x, "y": y, "yaw": yaw}
            record.teleop = False
        elif not event.navigating:
            record.goal = None

    def goal(self, robot: str) -> GoalDescription | None:
        """The goal the robot follows now, or None."""
        record = self._robots[robot]
        return record.goal if record.navigating else None

    def set_teleop(self, robot: str, active: bool) -> None:
        """An operator drives the robot with cmd_vel (which overrides navigation), or stopped doing so."""
        record = self._robots[robot]
        record.teleop = active
        if active:
            record.navigating = False
            record.goal = None

    def set_estopped(self, robot: str, latched: bool) -> None:
        """Whether the robot's emergency stop is latched, reported as the status' ``estopped``."""
        self._robots[robot].estopped = latched

    def set_controller(self, robot: str, controller: str | None) -> None:
        """The lease holder, reported as the status' ``controller``."""
        self._robots[robot].controller = controller

    def busy(self) -> set[str]:
        """Robots navigating or driven: their leases do not expire."""
        return {name for name, r in self._robots.items() if r.teleop or r.navigating}

    def online(self, robot: str, now: float) -> bool:
        last = self._robots[robot].last_data
        return last is not None and now - last < self.offline_after

    def status(self, robot: str, now: float) -> StatusMessage:
        record = self._robots[robot]
        mode: Mode = "teleop" if record.teleop else "navigating" if record.navigating else "idle"
        age = None if record.last_data is None else max(0.0, now - record.last_data)
        return status_message(
            robot,
            online=self.online(robot, now),
            age=age,
            mode=mode,
            goal=record.goal,
            controller=record.controller,
            estopped=record.estopped,
        )

    def snapshot(self, now: float) -> dict[str, RobotState]:
        return {
            name: {"pose": r.pose, "sensors": dict(r.sensors), "status": self.status(name, now)}
            for name, r in self._robots.items()
        }

    def positions(self, now: float) -> dict[str, tuple[float, float]]:
        """Where each online robot with a pose stands (map frame): what a new goal must keep clear of."""
        return {
            name: (r.pose["x"], r.pose["y"])
            for name, r in self._robots.items()
            if r.pose is not None and self.online(name, now)
        }

    def robots_online(self, now: float) -> int:
        return sum(self.online(name, now) for name in self._robots)
