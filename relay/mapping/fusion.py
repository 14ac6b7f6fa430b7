"""Every robot's clouds fused into the site's one voxel map, on one worker thread, never on the event loop.

The map (:class:`relay.cloud.voxels.VoxelMap`) is not thread-safe, so one thread owns it: every integration, every
encoding of its blocks for clients (relay/mapping/stream.py) and every save runs on this service's one worker, one
after another, through :meth:`MapFusion.run`. A fusion of a sim depth cloud (16 000 points) into a map of 120 000
voxels took 28 ms (median of 60, this 2-core machine at load average 20); a 300 000-point lidar cloud 105-120 ms
(relay/cloud/voxels.py), so clouds can come faster than they fuse.

**The queue** is the newest cloud of each robot, no more: a robot's cloud that arrives while its previous one still
waits replaces it (``dropped`` counts them), and robots take turns in the order their clouds arrived. Its size is
bounded by the fleet's; a cloud never waits behind more than one of each other robot's.

**The file**: the map is saved beside the inspection database (``<database>.voxels.npz``, relay/cloud/map_file.py:
written atomically) every ``cloud.save_every`` seconds when it changed, and when the relay stops; it is loaded when the
relay starts, so the map survives a restart. A file that cannot be read (another voxel size, a truncated write of an
older relay) is moved aside to ``.unreadable`` with a warning naming it and why, and the map starts empty. Without a
database file (a temporary database, or PostgreSQL) the map lives as long as the relay.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TypeVar

import numpy as np

from ..cloud.errors import CloudError
from ..cloud.voxels import Integration, VoxelMap
from ..config import Cloud
from ..fleet.events import CloudEvent
from ..station.work import Busy, WorkPool

logger = logging.getLogger(__name__)

T = TypeVar("T")


def map_path(database: str | None) -> Path | None:
    """The map's file beside the inspection database ``database`` (a SQLite file), or None (temporary, PostgreSQL)."""
    if database is None or database.startswith(("postgresql://", "postgres://")):
        return None
    path = Path(database).expanduser().absolute()
    return path.with_name(path.name + ".voxels.npz")


@dataclass
class FusionCounters:
    """Totals since start (/metrics)."""

    received: int = 0
    integrated: int = 0
    dropped: int = 0  # replaced by the same robot's newer cloud before they were fused
    failed: int = 0  # refused by the map (named in the log)
    saves: int = 0
    #: The last cloud the map refused, and why (/healthz).
    last_failure: str | None = None


class MapFusion:
    """The site's voxel map and the one thread that touches it."""

    def __init__(self, settings: Cloud, path: Path | None) -> None:
        self.settings = settings
        self.path = path
        self.counters = FusionCounters()
        #: The map's version as of the last integration (read on the loop; the map itself is the worker's).
        self.version = 0
        self._map = VoxelMap(settings.voxel, settings.budget_blocks)
        self._saved_version = 0
        self._pending: dict[str, CloudEvent] = {}
        self._wake = asyncio.Event()
        self._listeners: list[Callable[[int], None]] = []
        # One worker owns the map; waiting: the stream's one encoding and one save beside an integration.
        self._pool = WorkPool("fusion", workers=1, queue=2)
        self._tasks: list[asyncio.Task[None]] = []
        self._stopping = False

    @property
    def voxel(self) -> float:
        return self._map.voxel

    def health(self) -> dict[str, object]:
        """What /healthz says of the map: its version, file and counters."""
        return {"version": self.version, "file": None if self.path is None else str(self.path),
                "waiting": len(self._pending), **dataclasses.asdict(self.counters)}  # fmt: skip

    def on_version(self, listener: Callable[[int], None]) -> None:
        """Call ``listener(version)`` on the loop after every integration that changed the map."""
        self._listeners.append(listener)

    def submit(self, cloud: CloudEvent) -> None:
        """A robot's cloud, to fuse when the worker is free (on the loop; never waits)."""
        self.counters.received += 1
        if cloud.robot in self._pending:
            self.counters.dropped += 1
        self._pending[cloud.robot] = cloud  # a replaced robot keeps its turn
        self._wake.set()

    async def run(self, work: Callable[[VoxelMap], T]) -> T:
        """``work(map)`` on the map's thread (Busy, relay.station.work, when its queue is full)."""
        voxels = self._map
        return await self._pool.run(lambda: work(voxels))

    # -- lifecycle ---------------------------------------------------------------------------------

    async def start(self) -> None:
        if self.path is not None:
            self._map = await self._pool.run(self._load)
            self.version = self._saved_version = self._map.version
        loop = asyncio.get_running_loop()
        self._tasks = [loop.create_task(self._fuse(), name="map-fusion"), loop.create_task(self._autosave())]

    async def stop(self) -> None:
        # The fusing task ends after the integration in hand (cancelled, it would leave that one running on the
        # worker, unrecorded here, and the last save would hold a version this service never announced).
        self._stopping = True
        self._wake.set()
        for task in reversed(self._tasks):
            if task.get_name() != "map-fusion":
                task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks.clear()
        await self.save()
        self._pool.shutdown()

    async def save(self) -> None:
        """Write the map to its file, when it has one and changed since the last save (errors are logged)."""
        if self.path is None or self.version == self._saved_version:
            return
        version, path = self.version, self.path
        try:
            await self.run(lambda voxels: voxels.save(path))
        except (OSError, Busy) as exc:
            logger.error("cannot save the voxel map to %s: %s", path, exc)
            return
        self._saved_version = version
        self.counters.saves += 1

    # -- the worker's side -------------------------------------------------------------------------

    def _load(self) -> VoxelMap:
        assert self.path is not None
        if not self.path.exists():  # the first run beside this database
            return self._map
        try:
            loaded = VoxelMap.load(self.path, self.settings.budget_blocks)
            if abs(loaded.voxel - self.settings.voxel) > 1e-9:
                raise CloudError(f"voxel map {self.path} has {loaded.voxel:g} m voxels, robots.yaml asks for "
                                 f"{self.settings.voxel:g}")  # fmt: skip
        except (CloudError, OSError) as exc:
            aside = self.path.with_name(self.path.name + ".unreadable")
            logger.warning("%s; moved to %s, the map starts empty", exc, aside)
            with contextlib.suppress(OSError):
                self.path.replace(aside)
            return VoxelMap(self.settings.voxel, self.settings.budget_blocks)
        logger.info("voxel map loaded from %s: %d voxels in %d blocks", self.path, len(loaded), len(loaded.blocks))
        return loaded

    async def _fuse(self) -> None:
        while not self._stopping:
            await self._wake.wait()
            self._wake.clear()
            while self._pending and not self._stopping:
                cloud = self._pending.pop(next(iter(self._pending)))
                try:
                    done = await self.run(partial(_integrate, cloud))
                except (ValueError, CloudError) as exc:
                    self.counters.failed += 1
                    self.counters.last_failure = f"{cloud.robot}'s cloud of {len(cloud.points)} points: {exc}"
                    logger.warning("%s not fused", self.counters.last_failure)
                    continue
                self.counters.integrated += 1
                if done.version != self.version:
                    self.version = done.version
                    for listener in self._listeners:
                        listener(done.version)

    async def _autosave(self) -> None:
        while True:
            await asyncio.sleep(self.settings.save_every)
            await self.save()


def _integrate(cloud: CloudEvent, voxels: VoxelMap) -> Integration:
    """Fuse ``cloud``, its points that are not finite numbers left out; a CloudError naming what is wrong with it."""
    points, pose = np.asarray(cloud.points), np.asarray(cloud.pose)
    if points.ndim != 2 or points.shape[1] != 3:
        raise CloudError(f"points of shape {points.shape}, expected (N, 3)")
    if pose.shape != (4, 4) or not np.isfinite(pose).all():
        raise CloudError(f"a sensor pose of shape {pose.shape} that is not a finite 4x4 matrix")
    finite = np.isfinite(points).all(axis=1)
    rgb = None if cloud.rgb is None else np.asarray(cloud.rgb)[finite]
    return voxels.integrate(points[finite], pose, cloud.stamp, rgb)
