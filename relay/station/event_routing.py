"""Backend events to what clients are told: poses, sensors, navigation, paths, scans, camera frames, maps and
models, each to the part that holds it (always on the loop thread)."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Mapping

from ..config import Robot
from ..control.arm_control import ArmControl
from ..control.control import Control
from ..fleet.events import (
    AvatarEvent,
    CameraError,
    CancelAnswerEvent,
    CloudEvent,
    Event,
    FrameEvent,
    GateStateEvent,
    Goal,
    JointStateEvent,
    MapEvent,
    NavEvent,
    NavFeedbackEvent,
    PathEvent,
    PlaybackEvent,
    PoseEvent,
    RobotModelEvent,
    ScanEvent,
    SensorEvent,
    ValveEvent,
)
from ..fleet.latency import StageLatency
from ..fleet.occupancy import OccupancyGrid
from ..fleet.state import FleetState
from ..inspection.service import Inspection
from ..media.streams import CameraStreams
from ..session.protocol import camera_identifier
from ..sim.valve_wire import ValveMessage, valve_message
from .assets import GeneratedAssets
from .messages import (
    GoalDescription,
    NavFeedback,
    PlaybackMessage,
    avatar_message,
    nav_message,
    path_message,
    playback_message,
    scan_message,
)
from .outbox import Outbox

logger = logging.getLogger(__name__)


class EventRouter:
    def __init__(
        self,
        robots: Mapping[str, Robot],
        fleet: FleetState,
        outbox: Outbox,
        assets: GeneratedAssets,
        streams: CameraStreams,
        control: Control,
        inspection: Inspection,
        latency: StageLatency,
        clock: Callable[[], float],
        arms: ArmControl,
        clouds: Callable[[CloudEvent], None] | None = None,
        *,
        reached: Callable[[str], None] = lambda robot: None,
    ) -> None:
        """``clouds``: where the robots' clouds go (the 3D map's fusion, relay.mapping); None: nowhere. ``reached``:
        told each robot that reached a goal (a study's task, relay.study.service)."""
        self.robots = robots
        self.fleet = fleet
        self.outbox = outbox
        self.assets = assets
        self.streams = streams
        self.control = control
        self.inspection = inspection
        self.latency = latency
        self.clock = clock
        self.arms = arms
        self.clouds = clouds
        self.reached = reached
        self.live_map: OccupancyGrid | None = None  # from the backend's /map
        self.playback: PlaybackMessage | None = None  # the latest `playback` message (bag backend)
        self.valve: ValveMessage | None = None  # the latest `valve` message (sim backend), for clients that connect

    def on_event(self, event: Event) -> None:
        if isinstance(event, PlaybackEvent):
            fields = dataclasses.asdict(event)
            del fields["robot"]  # fleet-wide
            self.playback = playback_message(**fields)
            self.outbox.state(self.playback)
        elif isinstance(event, AvatarEvent):
            self.outbox.broadcast(avatar_message(event.client, event.name, event.stamp, event.head, event.hands))
        elif isinstance(event, ValveEvent):
            self.valve = valve_message(event)
            self.outbox.broadcast(self.valve)
        elif isinstance(event, MapEvent):
            self.live_map = event.grid
            logger.info("map received: %dx%d cells, bounds %s", event.grid.width, event.grid.height, event.grid.bounds)
            self.assets.on_map(event)
        elif event.robot not in self.robots:
            logger.warning("backend reported unknown robot %r; ignored", event.robot)
        elif isinstance(event, RobotModelEvent):
            self.assets.on_model(event)
        else:
            self._on_robot_event(event, self.clock())

    def _on_robot_event(self, event: Event, now: float) -> None:
        if isinstance(event, PoseEvent):
            self.latency.stamped(event.robot, "pose", event.stamp)
            message = self.fleet.on_pose(event, now)
            self.outbox.state(message)
            if self.outbox.online_changed(event.robot, now):
                self.outbox.status(event.robot, now)
        elif isinstance(event, SensorEvent):
            sensor = self.fleet.on_sensor(event)
            if sensor is not None:
                self.outbox.state(sensor)
        elif isinstance(event, NavEvent):
            self.fleet.on_nav(event)
            self.outbox.status(event.robot, now)
            self.outbox.state(
                nav_message(
                    event.robot, outcome=event.outcome, goal=_goal(event.goal), message=event.message,
                    error_code=event.error_code,
                )
            )  # fmt: skip
            self.inspection.on_nav(event)
            if event.outcome == "reached":
                self.reached(event.robot)
        elif isinstance(event, NavFeedbackEvent):
            goal = _goal(event.goal)
            if goal == self.fleet.goal(event.robot):  # the goal it follows now, not one being given up
                feedback = NavFeedback(
                    distance_remaining=event.distance_remaining, eta=event.eta, recoveries=event.recoveries,
                    navigation_time=event.navigation_time,
                )  # fmt: skip
                self.outbox.state(nav_message(event.robot, outcome="started", goal=goal, message="", feedback=feedback))
        elif isinstance(event, CancelAnswerEvent):
            self.outbox.state(
                nav_message(
                    event.robot, outcome="cancelled", goal=_goal(event.goal), message=event.message,
                    confirmed=event.confirmed,
                )
            )  # fmt: skip
        elif isinstance(event, GateStateEvent):
            if event.word == "estop":
                self.control.watchdog_estop(event.robot, now)
        elif isinstance(event, PathEvent):
            self.outbox.state(path_message(event.robot, event.points))
        elif isinstance(event, ScanEvent):
            # Not dataclasses.asdict: it deep-copies the ranges (a third of the relay's time at 1000 scans/s).
            scan = scan_message(
                event.robot,
                stamp=event.stamp,
                frame=event.frame,
                angle_min=event.angle_min,
                angle_increment=event.angle_increment,
                range_max=event.range_max,
                ranges=event.ranges,
            )
            self.outbox.state(scan)
        elif isinstance(event, JointStateEvent):
            joints = self.arms.on_joints(event)
            if joints is not None:
                self.outbox.broadcast(joints)
        elif isinstance(event, CloudEvent):
            if self.clouds is not None:
                self.clouds(event)
        elif isinstance(event, FrameEvent):
            self.latency.stamped(event.robot, "picture", event.stamp)
            self.streams.on_frame(event, now)
        elif isinstance(event, CameraError):
            self.streams.camera_failed(camera_identifier(event.robot, event.camera), event.message)


def _goal(goal: Goal | None) -> GoalDescription | None:
    return None if goal is None else GoalDescription(x=goal[0], y=goal[1], yaw=goal[2])
