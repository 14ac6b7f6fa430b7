"""The live 3D map to every client: the blocks each lacks since the version it holds, the whole map first.

Each client's map lane (relay/station/map_lane.py) remembers the version its client will hold. Whenever the map changes
(and at least every :data:`PERIOD`, for clients that just connected), the clients whose lane is idle and whose version
is behind are grouped by that version; for each group the map's thread encodes what it lacks once
(:meth:`relay.cloud.voxels.VoxelMap.changed_since`, :func:`relay.cloud.blocks_wire.encode_block`), and every client of
the group is sent the same bytes: a ``voxel_map`` text message, then the block records in binary frames of at most
:data:`MAX_FRAME` bytes. In the common case every client is at the same version and one encoding serves them all. The
whole map for a new client is the dearest: 123 000 voxels in 845 blocks (60 sim depth clouds at 5 cm) took 103 ms on
the map's thread and made 270 kB in 6 frames (load average 20).

At most one batch a :data:`PERIOD` per client: a map fed 15 clouds a second changes 15 times a second, and a browser
gains nothing from drawing each. A client that reads slowly gets fewer, larger batches, never a backlog.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections import defaultdict
from functools import partial
from typing import Final

from ..cloud.blocks_wire import encode_block
from ..cloud.voxels import VoxelMap
from ..station.hub import Channel, Hub
from ..station.messages import encode, voxel_map_message
from ..station.work import Busy
from .fusion import MapFusion

logger = logging.getLogger(__name__)

#: Seconds between two batches to a client, at least.
PERIOD: Final = 0.25
#: A binary frame's size, at most (one record may exceed it: a full block of colours is 16 412 bytes, well under).
#: A pose that arrives while a map frame goes out waits for that frame: 64 kB take 0.5 ms on loopback, 5 ms at 100 Mb/s.
MAX_FRAME: Final = 64 * 1024

#: The map's thread lets the loop's thread run after encoding this many blocks: a whole map's hundreds of blocks in
#: one go held the interpreter while poses waited (bench/bench_map_beside.py: the pose p99 beside a streaming map fell
#: from 7.2-7.5 ms to 4.3-5.6 ms with it, over two runs; 0.5 ms without the map).
YIELD_EVERY: Final = 16

Batch = list[tuple[bool, bytes]]


def encode_changes(since: int, voxels: VoxelMap) -> tuple[Batch, int]:
    """What a client that holds the map at ``since`` lacks, as its frames, and the version they bring it to. On the
    map's thread."""
    changes = voxels.changed_since(since)
    frames: list[bytes] = []
    pending: list[bytes] = []
    size = 0
    for k, block in enumerate(changes.blocks):
        if k % YIELD_EVERY == YIELD_EVERY - 1:
            time.sleep(0)  # the interpreter to the loop's thread now and then (see YIELD_EVERY)
        record = encode_block(block, voxels.voxel)
        if pending and size + len(record) > MAX_FRAME:
            frames.append(b"".join(pending))
            pending, size = [], 0
        pending.append(record)
        size += len(record)
    if pending:
        frames.append(b"".join(pending))
    header = voxel_map_message(
        version=changes.version, since=since, reset=changes.reset or since == 0, voxel=voxels.voxel,
        blocks=len(changes.blocks), frames=len(frames),
    )  # fmt: skip
    return [(False, encode(header)), *((True, frame) for frame in frames)], changes.version


class MapStream:
    def __init__(self, hub: Hub, fusion: MapFusion, period: float = PERIOD) -> None:
        self.hub = hub
        self.fusion = fusion
        self.period = period
        #: Batches encoded, and batches sent (one encoding serves every client at the same version).
        self.encoded = self.sent = 0
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        fusion.on_version(lambda version: self._wake.set())

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name="map-stream")

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    async def _run(self) -> None:
        while True:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._wake.wait(), self.period)
            self._wake.clear()
            try:
                await self.catch_up()
            except Busy as exc:  # the map's thread is saving and fusing: the next turn
                logger.debug("map stream waits: %s", exc)
            await asyncio.sleep(self.period)

    async def catch_up(self) -> None:
        """Send every idle client that is behind what it lacks."""
        behind: dict[int, list[Channel]] = defaultdict(list)
        for channel in self.hub:
            if not channel.closed and channel.map.idle and channel.map.version != self.fusion.version:
                behind[channel.map.version].append(channel)
        for since, channels in behind.items():
            frames, version = await self.fusion.run(partial(encode_changes, since))
            self.encoded += 1
            for channel in channels:
                if channel.map.version == since and channel.put_map(frames, version):
                    self.sent += 1
