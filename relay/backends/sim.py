"""The built-in simulated fleet: the default backend, so the main command works with no ROS at all.

A thin asyncio adapter over :class:`relay.sim.world.SimWorld`: the world is integrated at
``sim.physics_rate`` (>= 50 Hz), poses are published at ``sim.pose_rate`` whether the robots move or not (as
odometry is), sensors at ``sim.sensor_rate``, and a 360-beam laser scan of the walls (relay.sim.laser) of each
robot that has a ``scan`` at ``sim.scan_rate``. Planning a goal runs in a pool of its own, never on the loop;
so do the scans (about 2.5 ms of numpy each on this project's 2-core machine: 3 robots at 5 Hz would
otherwise take ~4 % of the loop's time in slices that delay every frame sent meanwhile).

Cameras: each camera of robots.yaml sees the scene's glTF through its lens, ray cast by
:class:`relay.sim.camera.SimCamera` in a worker thread (about 65-115 ms for 480x480 with Embree on 2 cores).
A stream renders at most one frame at a time per camera, at up to the rate asked for; renders (streams and
snapshots) share one rendering thread with a bounded queue (relay.station.work).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from functools import partial
from typing import Any

from ..config import FleetConfig
from ..errors import BackendUnavailable, CommandRejected
from ..fleet.events import EventSink, FrameEvent, NavEvent, PathEvent, PoseEvent, ScanEvent, SensorEvent
from ..fleet.geometry import yaw_to_quaternion
from ..fleet.occupancy import OccupancyGrid
from ..fleet.scan import decimate_ranges
from ..media.lens import LensModel
from ..session.budget import TOTAL as SNAPSHOTS_AT_ONCE
from ..session.protocol import ErrorCode
from ..sim.camera import SimCamera, rgb_to_jpeg
from ..sim.laser import LaserScanner
from ..sim.world import Goal, NoPathError, Outcome, SimWorld
from ..station.work import Busy, WorkPool
from ..twin.frames import map_to_scene_matrix
from .base import Backend

logger = logging.getLogger(__name__)


class SimBackend(Backend):
    name = "sim"

    def __init__(self, config: FleetConfig, sink: EventSink) -> None:
        super().__init__(config, sink)
        self._world: SimWorld | None = None
        self._task: asyncio.Task[None] | None = None
        self.camera: SimCamera | None = None
        self._lenses: dict[tuple[str, str], LensModel] = {}
        self._streams: dict[tuple[str, str], tuple[float, asyncio.Task[None]]] = {}
        # Pools of their own (relay.station.work), not asyncio's default one that anything can fill. One render thread:
        # the other core stays for the event loop and planning. The rendering queue holds every camera's stream
        # frame (one each) and the snapshot budget's total (relay.session.budget), so a snapshot within budget never
        # finds it full.
        cameras = sum(len(robot.cameras) for robot in config.robots)
        self._planning = WorkPool("planning", workers=1, queue=4)
        self._rendering = WorkPool("rendering", workers=1, queue=cameras + SNAPSHOTS_AT_ONCE)
        # One sweep of every robot's scan at a time: when it is slower than the period, scans come less often.
        self._scanning = WorkPool("scanning", workers=1, queue=1)
        self._scanner: LaserScanner | None = None
        self._scanned = [r.name for r in config.robots if r.scan_topic is not None]
        self._scan_task: asyncio.Task[None] | None = None

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
        glb = self.world.scene_glb
        cameras = [(r, c) for r in self.config.robots for c in r.cameras]
        if cameras and glb is None:
            logger.warning("sim: no scene glTF to look at (sim.world); the simulated cameras stay dark")
        elif cameras and glb is not None:
            m = self.config.scene.map_to_scene
            self.camera = await asyncio.to_thread(
                SimCamera.load, glb, map_to_scene=map_to_scene_matrix(m.x, m.y, m.z, m.yaw)
            )
            for robot, cam in cameras:
                self._lenses[(robot.name, cam.name)] = self.camera.fit_lens(cam.lens, cam.width, cam.height)
            logger.info("sim: %d cameras render %s with %s", len(cameras), glb.name, self.camera.engine)
        loop = asyncio.get_running_loop()
        self._task = loop.create_task(self._run(), name="sim-backend")
        if self._scanned:
            self._scanner = LaserScanner(self.world.grid)
            self._scan_task = loop.create_task(self._scan(), name="sim-scans")

    async def stop(self) -> None:
        for _, task in self._streams.values():
            task.cancel()
        self._streams.clear()
        if self._scan_task is not None:
            self._scan_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._scan_task
        self._planning.shutdown()
        self._rendering.shutdown()
        self._scanning.shutdown()
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

    # -- cameras ----------------------------------------------------------------------------------

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        lens = self._lenses.get((robot, camera))
        if self.camera is None or lens is None:
            return None
        # Plain floats cross to the worker thread: the world keeps moving on the loop meanwhile.
        (x, y, yaw), stamp = self._pose_of(robot), time.time()
        render, spill = self.camera.render, self.world.spill_at()  # the spill as grown at this frame's time

        def work() -> tuple[bytes, Any]:
            rgb = render(x, y, yaw, lens, spill=spill)
            return rgb_to_jpeg(rgb), rgb[:, :, ::-1]  # BGR, a view: the H.264 encoder takes it as it is

        try:
            jpeg, bgr = await self._rendering.run(work)
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"{robot}/snapshot: {exc}; try again shortly") from None
        return FrameEvent(robot, camera, stamp, lens.width, lens.height, jpeg, bgr)

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        key = (robot, camera)
        current = self._streams.pop(key, None)
        if current is not None:
            current[1].cancel()
        if fps > 0 and self.camera is not None:
            task = asyncio.get_running_loop().create_task(self._stream(robot, camera, fps), name=f"sim-camera-{robot}")
            self._streams[key] = (fps, task)

    async def _stream(self, robot: str, camera: str, fps: float) -> None:
        loop = asyncio.get_running_loop()
        period = 1.0 / fps
        while True:
            started = loop.time()
            with contextlib.suppress(CommandRejected):  # the rendering pool is full: this frame is skipped
                frame = await self.snapshot(robot, camera)
                if frame is not None:
                    self.sink(frame)
            # One render in flight: when rendering is slower than the period, the rate drops instead of
            # frames piling up.
            await asyncio.sleep(max(0.0, period - (loop.time() - started)))

    # -- the simulation loop ----------------------------------------------------------------------

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        sim_cfg = self.config.sim
        dt = 1.0 / max(sim_cfg.physics_rate, 50.0)
        pose_period = 1.0 / sim_cfg.pose_rate
        sensor_period = 1.0 / sim_cfg.sensor_rate
        now = loop.time()
        next_tick = next_pose = next_sensor = now
        while True:
            self.world.step(dt)
            stamp = time.time()
            now = loop.time()
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

    async def _scan(self) -> None:
        """Every robot's scan from where it is now, at ``sim.scan_rate`` (or slower when a sweep takes longer)."""
        loop = asyncio.get_running_loop()
        period = 1.0 / self.config.sim.scan_rate
        scanner = self._scanner
        assert scanner is not None
        while True:
            started = loop.time()
            # Plain floats cross to the worker thread: the world keeps moving on the loop meanwhile.
            poses = [(name, *self._pose_of(name)) for name in self._scanned]
            stamp = time.time()
            with contextlib.suppress(Busy):
                for name, ranges in await self._scanning.run(partial(_sweep, scanner, poses)):
                    frame, increment = f"{name}/base_scan", scanner.angle_increment
                    self.sink(ScanEvent(name, stamp, frame, scanner.angle_min, increment, scanner.range_max, ranges))
            await asyncio.sleep(max(0.0, period - (loop.time() - started)))

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


def _sweep(scanner: LaserScanner, poses: list[tuple[str, float, float, float]]) -> list[tuple[str, tuple[float, ...]]]:
    """Each robot's ranges as ScanEvent carries them (no return: NaN), all of it in the worker thread."""
    sweep = []
    for name, x, y, yaw in poses:
        ranges, _ = decimate_ranges(scanner.scan(x, y, yaw), scanner.range_min, scanner.range_max)
        sweep.append((name, tuple(ranges.tolist())))
    return sweep
