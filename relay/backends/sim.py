"""The built-in simulated fleet: the default backend, so the main command works with no ROS at all.

A thin asyncio adapter over :class:`relay.sim.world.SimWorld`: the world is integrated at
``sim.physics_rate`` (>= 50 Hz), poses are published at ``sim.pose_rate`` whether the robots move or not (as
odometry is), sensors at ``sim.sensor_rate``, and a 360-beam laser scan of the walls (relay.sim.laser) of each
robot that has a ``scan`` at ``sim.scan_rate``. Planning a goal runs in a pool of its own, never on the loop;
so do the scans (about 2.5 ms of numpy each on this project's 2-core machine: 3 robots at 5 Hz would
otherwise take ~4 % of the loop's time in slices that delay every frame sent meanwhile).

Cameras (relay.backends.sim_cameras): each camera of robots.yaml sees the scene's glTF through its lens, from its
robot or from the gripper it rides on, rendered in one worker thread with a bounded queue.

Arms (relay.sim.arms): every robot whose ``arm:`` could be read carries a simulated arm, stepped with the world and
its joints published at ``JOINT_STATE_RATE``; one whose files are absent runs without it (the log and /healthz's
``arms`` say why). Every stop of a robot (``stop_robot``: a take-over, a lease's end, shutdown; an estop) stops its
arm too, and an estop latches it until the reset.

Depth (issue #33, with robots.yaml's ``cloud``): every robot's depth camera casts its rays against the same scene
(relay.backends.sim_feeds).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from functools import partial
from typing import Any

from ..arm.fleet_arms import FleetArms, load_fleet_arms
from ..arm.named import JointGoal
from ..config import FleetConfig
from ..errors import BackendUnavailable, CommandRejected
from ..fleet.events import EventSink, FrameEvent, NavEvent, PathEvent, PoseEvent, SensorEvent
from ..fleet.geometry import yaw_to_quaternion
from ..fleet.occupancy import OccupancyGrid
from ..session.protocol import ErrorCode
from ..sim.arms import JOINT_STATE_RATE, SimArms
from ..sim.depth_camera import SimDepthCamera
from ..sim.laser import LaserScanner
from ..sim.world import Goal, NoPathError, Outcome, SimWorld
from ..station.work import Busy, WorkPool
from .base import Backend, Vec3
from .sim_cameras import SimCameras
from .sim_feeds import SweepFeed, depth_feed, scan_feed

logger = logging.getLogger(__name__)


class SimBackend(Backend):
    name = "sim"

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        super().__init__(config, sink)
        self._world: SimWorld | None = None
        self._task: asyncio.Task[None] | None = None
        # A pool of its own (relay.station.work), not asyncio's default one that anything can fill.
        self._planning = WorkPool("planning", workers=1, queue=4)
        # Scans and depth clouds: one sweep of every robot at a time (relay.backends.sim_feeds), made in start().
        self._scanned = [r.name for r in config.robots if r.scan_topic is not None]
        self._feeds: list[SweepFeed[Any]] = []
        self._arms = SimArms({}, FleetArms(), config.safety.deadman_timeout)  # read in start()
        #: The cameras (relay.backends.sim_cameras): each renders from its robot, or from the gripper it rides on.
        self.cameras = SimCameras(config, sink, self._pose_of, lambda: self._arms, lambda: self.world.spill_at())
        self._depth_rate = config.cloud.sim_depth_rate if config.cloud is not None else 0.0  # issue #33

    def _on_nav(self, robot: str, navigating: bool, goal: Goal | None, outcome: Outcome, message: str) -> None:
        self.sink(NavEvent(robot, navigating, goal, outcome, message))
        if not navigating:
            self.sink(PathEvent(robot, ()))  # the plan ends with the goal, however it ended

    @property
    def world(self) -> SimWorld:
        if self._world is None:
            raise RuntimeError("the sim backend has not started")
        return self._world

    async def start(self) -> None:
        try:
            # Parsing the scene file and preparing the planner take a while: not on the event loop.
            self._world = await asyncio.to_thread(SimWorld, self.config, self._on_nav)
        except ValueError as exc:
            raise BackendUnavailable(f"the simulated world cannot be loaded: {exc}") from None
        robots = {r.name: r for r in self.config.robots}
        loaded = await asyncio.to_thread(load_fleet_arms, self.config.robots)  # parsing URDFs: off the loop
        self._arms = SimArms(robots, loaded, self.config.safety.deadman_timeout)
        await self.cameras.load(self.world.scene_glb, needed=self._depth_rate > 0)
        loop = asyncio.get_running_loop()
        self._task = loop.create_task(self._run(), name="sim-backend")
        if self._scanned:
            scanned = partial(self._poses_of, self._scanned)
            rate = self.config.sim.scan_rate
            self._feeds.append(scan_feed(LaserScanner(self.world.grid), rate, scanned, self.sink))
        if self._depth_rate > 0 and self.cameras.camera is not None:
            every = partial(self._poses_of, list(self.world.robots))
            self._feeds.append(depth_feed(SimDepthCamera(self.cameras.camera), self._depth_rate, every, self.sink))

    async def stop(self) -> None:
        self.cameras.stop()
        for feed in self._feeds:
            await feed.stop()
        self._feeds.clear()
        self._planning.shutdown()
        if self._world is None:
            return
        for name in self.world.robots:
            await self.stop_robot(name)
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    def map_grid(self) -> OccupancyGrid | None:
        return self._world.grid if self._world is not None else None

    # -- commands ---------------------------------------------------------------------------------

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        self.world.set_velocity(robot, linear, angular)

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        try:
            # A* takes milliseconds to tens of them: off the event loop, in a pool no snapshot can fill.
            path = await self._planning.run(lambda: self.world.plan(robot, x, y))
        except NoPathError as exc:
            raise CommandRejected(ErrorCode.NO_PATH, f"{robot}/goal_pose: {exc}") from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"{robot}/goal_pose: {exc}; try again shortly") from None
        if current():  # an estop or a take-over while planning: the robot must not follow the old plan
            self.world.follow(robot, path, yaw)
            self.sink(PathEvent(robot, tuple(path)))

    async def cancel(self, robot: str) -> None:
        self.world.cancel(robot)

    # -- arms -------------------------------------------------------------------------------------

    def place_refusal(self, robot: str, x: float, y: float) -> CommandRejected | None:
        if not self.world.grid.is_free(x, y):
            return CommandRejected(ErrorCode.NO_PATH, f"{robot}: ({x:.2f}, {y:.2f}) is inside a wall or an obstacle")
        return None

    async def place(self, robot: str, x: float, y: float, yaw: float) -> None:
        refusal = self.place_refusal(robot, x, y)
        if refusal is not None:
            raise refusal
        self.world.place(robot, x, y, yaw)
        # Its pose at once, so that nothing above judges the robot by where it stood before.
        qx, qy, qz, qw = yaw_to_quaternion(yaw)
        self.sink(PoseEvent(robot, time.time(), "map", x, y, 0.0, qx, qy, qz, qw))

    async def send_arm_twist(self, robot: str, linear: Vec3, angular: Vec3) -> None:
        arm = self._arms.arm(robot, f"{robot}/arm/twist")
        _refused(f"{robot}/arm/twist", arm.servo(linear, angular, asyncio.get_running_loop().time()))

    async def send_arm_pose(self, robot: str, pose: str, goal: JointGoal) -> None:
        _refused(f"{robot}/arm/pose", self._arms.arm(robot, f"{robot}/arm/pose").named(pose))

    async def send_gripper(self, robot: str, command: str | float, position: float) -> None:
        _refused(f"{robot}/arm/gripper", self._arms.arm(robot, f"{robot}/arm/gripper").gripper(command))

    async def stop_arm(self, robot: str) -> None:
        self._arms.stop(robot)

    async def estop_robot(self, robot: str) -> None:
        arm = self._arms.arms.get(robot)
        if arm is not None:
            arm.estop()  # latched on the robot's side too, as MoveIt Servo's halt
        await self.stop_robot(robot)

    def release_estop(self, robot: str) -> None:
        arm = self._arms.arms.get(robot)
        if arm is not None:
            arm.reset_estop()

    def health(self) -> dict[str, object]:
        arms = self._arms.loaded.health()
        return {"arms": arms} if arms else {}

    # -- cameras ----------------------------------------------------------------------------------

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        frame: FrameEvent | None = await self.cameras.snapshot(robot, camera)
        return frame

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        self.cameras.set_stream(robot, camera, fps)

    # -- the simulation loop ----------------------------------------------------------------------

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        sim_cfg = self.config.sim
        dt = 1.0 / max(sim_cfg.physics_rate, 50.0)
        pose_period = 1.0 / sim_cfg.pose_rate
        sensor_period = 1.0 / sim_cfg.sensor_rate
        joints_period = 1.0 / JOINT_STATE_RATE
        now = loop.time()
        next_tick = next_pose = next_sensor = next_joints = now
        while True:
            self.world.step(dt)
            stamp = time.time()
            now = loop.time()
            self._arms.step(now)  # the loop's clock: the one twists arrive on (send_arm_twist)
            if self.world.valve is not None:  # the gripper of an arm beside it turns it (relay/sim/valve.py)
                self._arms.turn(self.world.valve, {name: self._pose_of(name) for name in self._arms}, self.world.time)
            if now >= next_joints:
                next_joints = max(next_joints + joints_period, now - joints_period)
                for event in self._arms.states(stamp):
                    self.sink(event)
                valve = self.world.valve.report() if self.world.valve is not None else None
                if valve is not None:  # the twin draws it turning (docs/protocol.md, valve)
                    self.sink(valve)
            if now >= next_pose:
                next_pose = max(next_pose + pose_period, now - pose_period)
                self._publish_poses(stamp)
            if now >= next_sensor:
                next_sensor = max(next_sensor + sensor_period, now - sensor_period)
                self._publish_sensors(stamp)
            next_tick += dt
            delay = next_tick - loop.time()
            if delay < -0.5:
                # The loop was starved (a debugger, a suspended laptop): resynchronise rather than
                # integrating a burst of catch-up steps.
                next_tick = loop.time()
                delay = 0.0
            await asyncio.sleep(max(0.0, delay))

    def _poses_of(self, robots: list[str]) -> list[tuple[str, float, float, float]]:
        return [(name, *self._pose_of(name)) for name in robots]

    def _pose_of(self, robot: str) -> tuple[float, float, float]:
        state = self.world.robots[robot].state
        return float(state.x), float(state.y), float(state.yaw)

    def _publish_poses(self, stamp: float) -> None:
        for name, sim in self.world.robots.items():
            qx, qy, qz, qw = yaw_to_quaternion(sim.state.yaw)
            self.sink(PoseEvent(name, stamp, "map", sim.state.x, sim.state.y, 0.0, qx, qy, qz, qw))

    def _publish_sensors(self, stamp: float) -> None:
        for name in self.world.robots:
            for sensor, value in self.world.readings(name):
                self.sink(SensorEvent(name, sensor, value, stamp))


def _refused(identifier: str, reason: str | None) -> None:
    if reason is not None:
        raise CommandRejected(ErrorCode.ARM_REFUSED, f"{identifier}: refused: {reason}")
