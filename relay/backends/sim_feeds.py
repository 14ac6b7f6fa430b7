"""The simulated fleet's periodic sweeps off the event loop: every robot's laser scan (``sim.scan_rate``) and, with
robots.yaml's ``cloud`` (issue #33), its depth cloud (``cloud.sim_depth_rate``: a 160x120 depth camera ray cast
against the facility mesh, ~10 ms a robot). Each sweep takes every robot's pose on the loop, computes in a thread
of its own and emits on the loop; a sweep still running when the next is due makes the next one wait, never queue.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable
from functools import partial
from typing import Generic, TypeVar

from ..fleet.events import CloudEvent, EventSink, ScanEvent
from ..fleet.scan import decimate_ranges
from ..sim.depth_camera import DepthScan, SimDepthCamera
from ..sim.laser import LaserScanner
from ..station.work import Busy, WorkPool

T = TypeVar("T")
#: A robot's name and pose (x, y, yaw in the map).
Pose = tuple[str, float, float, float]


class SweepFeed(Generic[T]):
    """``sweep`` (in the feed's thread) over the poses ``poses`` gives, ``rate`` times a second at most; ``emit``
    (on the loop) gets each robot's result with the sweep's stamp."""

    def __init__(
        self,
        name: str,
        rate: float,
        poses: Callable[[], list[Pose]],
        sweep: Callable[[list[Pose]], list[tuple[str, T]]],
        emit: Callable[[str, float, T], None],
    ) -> None:
        self.name, self.rate, self.poses, self.sweep, self.emit = name, rate, poses, sweep, emit
        self._pool = WorkPool(name, workers=1, queue=1)
        self._task = asyncio.get_running_loop().create_task(self._run(), name=f"sim-{name}")

    async def stop(self) -> None:
        self._task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await self._task
        self._pool.shutdown()

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        period = 1.0 / self.rate
        while True:
            started = loop.time()
            poses = self.poses()  # plain floats cross to the worker thread: the world keeps moving on the loop
            stamp = time.time()
            with contextlib.suppress(Busy):
                for name, result in await self._pool.run(partial(self.sweep, poses)):
                    self.emit(name, stamp, result)
            await asyncio.sleep(max(0.0, period - (loop.time() - started)))


def scan_feed(
    scanner: LaserScanner, rate: float, poses: Callable[[], list[Pose]], sink: EventSink
) -> SweepFeed[tuple[float, ...]]:
    """Every scanning robot's laser scan (ranges as ScanEvent carries them: no return is NaN)."""

    def sweep(at: list[Pose]) -> list[tuple[str, tuple[float, ...]]]:
        out = []
        for name, x, y, yaw in at:
            ranges, _ = decimate_ranges(scanner.scan(x, y, yaw), scanner.range_min, scanner.range_max)
            out.append((name, tuple(ranges.tolist())))
        return out

    def emit(name: str, stamp: float, ranges: tuple[float, ...]) -> None:
        s = scanner
        sink(ScanEvent(name, stamp, f"{name}/base_scan", s.angle_min, s.angle_increment, s.range_max, ranges))

    return SweepFeed("scanning", rate, poses, sweep, emit)


def depth_feed(
    camera: SimDepthCamera, rate: float, poses: Callable[[], list[Pose]], sink: EventSink
) -> SweepFeed[DepthScan]:
    """Every robot's depth cloud in the map frame, for the relay to fuse (relay/mapping/fusion.py)."""

    def sweep(at: list[Pose]) -> list[tuple[str, DepthScan]]:
        return [(name, camera.scan(x, y, yaw)) for name, x, y, yaw in at]

    def emit(name: str, stamp: float, scan: DepthScan) -> None:
        sink(CloudEvent(name, stamp, scan.points, scan.pose))

    return SweepFeed("depth", rate, poses, sweep, emit)
