"""The simulated fleet's cameras: each camera of robots.yaml sees the scene's glTF through its lens, ray cast by
:class:`relay.sim.camera.SimCamera` in a worker thread (about 65-115 ms for 480x480 with Embree on 2 cores), from its
robot, or from the gripper of the arm it rides on (robots.yaml ``arm.camera``: relay.sim.arms ``camera_pose``).

A stream renders at most one frame at a time per camera, at up to the rate asked for; renders (streams and
snapshots) share one rendering thread with a bounded queue (relay.station.work).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..config import FleetConfig
from ..errors import CommandRejected
from ..fleet.events import EventSink, FrameEvent
from ..media.lens import LensModel
from ..session.budget import TOTAL as SNAPSHOTS_AT_ONCE
from ..session.protocol import ErrorCode
from ..sim.arms import SimArms
from ..sim.camera import CAMERA_HEIGHT, SimCamera, rgb_to_jpeg
from ..sim.spill import GrownSpill
from ..station.work import Busy, WorkPool
from ..twin.frames import map_to_scene_matrix

logger = logging.getLogger(__name__)


class SimCameras:
    """``pose_of``: a robot's x, y and yaw now; ``arms``: the fleet's arms (read when a frame is made); ``spill``:
    the spill as grown now."""

    def __init__(
        self,
        config: FleetConfig,
        sink: EventSink,
        pose_of: Callable[[str], tuple[float, float, float]],
        arms: Callable[[], SimArms],
        spill: Callable[[], GrownSpill | None],
    ) -> None:
        self.config, self.sink, self.pose_of, self.arms, self.spill = config, sink, pose_of, arms, spill
        self.camera: SimCamera | None = None
        self._lenses: dict[tuple[str, str], LensModel] = {}
        #: The cameras on a gripper (robots.yaml ``arm.camera``): rendered from the arm's tip, not the base.
        self._on_arms = {(r.name, r.arm.camera) for r in config.robots if r.arm is not None and r.arm.camera}
        self._streams: dict[tuple[str, str], tuple[float, asyncio.Task[None]]] = {}
        # One render thread: the other core stays for the event loop and planning. The queue holds every camera's
        # stream frame (one each) and the snapshot budget's total (relay.session.budget), so a snapshot within budget
        # never finds it full.
        cameras = sum(len(robot.cameras) for robot in config.robots)
        self._rendering = WorkPool("rendering", workers=1, queue=cameras + SNAPSHOTS_AT_ONCE)

    async def load(self, glb: Path | None, *, needed: bool) -> None:
        """Load the scene the cameras look at (``needed``: also without cameras, for the depth cameras)."""
        cameras = [(r, c) for r in self.config.robots for c in r.cameras]
        if not (cameras or needed):
            return
        if glb is None:
            logger.warning("sim: no scene glTF to look at (sim.world); the simulated cameras stay dark")
            return
        m = self.config.scene.map_to_scene
        self.camera = await asyncio.to_thread(
            SimCamera.load, glb, map_to_scene=map_to_scene_matrix(m.x, m.y, m.z, m.yaw)
        )
        for robot, cam in cameras:
            self._lenses[(robot.name, cam.name)] = self.camera.fit_lens(cam.lens, cam.width, cam.height)
        logger.info("sim: %d cameras render %s with %s", len(cameras), glb.name, self.camera.engine)

    def stop(self) -> None:
        for _, task in self._streams.values():
            task.cancel()
        self._streams.clear()
        self._rendering.shutdown()

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        lens = self._lenses.get((robot, camera))
        if self.camera is None or lens is None:
            return None
        # Plain floats cross to the worker thread: the world keeps moving on the loop meanwhile.
        (x, y, yaw), stamp = self.pose_of(robot), time.time()
        height, pitch, arms = CAMERA_HEIGHT, 0.0, self.arms()
        if (robot, camera) in self._on_arms and robot in arms.arms:  # it rides on the gripper
            x, y, height, yaw, pitch = arms.camera_pose(robot, (x, y, yaw))
        render, spill = self.camera.render, self.spill()  # the spill as grown at this frame's time

        def work() -> tuple[bytes, Any]:
            rgb = render(x, y, yaw, lens, height=height, pitch=pitch, spill=spill)
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
