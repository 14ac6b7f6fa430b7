"""A site's voxel map: occupied voxels, fed by every robot's clouds, in blocks of 16³ that clients fetch when changed.

**Storage**: sorted arrays (:mod:`relay.cloud.voxel_keys`): each occupied voxel's key, hits, the time it was last
seen and its colour; each block's key, version and last-seen time. An integration is a handful of whole-array numpy
operations (a sort of the cloud's voxel keys, searches into the map's), never a Python loop per voxel or per block:
a 300 000-point cloud into a map of a million voxels fuses in 105-120 ms (median; 52-77 ms at best) on this 2-core
machine when quiet (bench/bench_cloud_fusion.py): #33's 10 Hz under one core is not met yet.

**An integration** (:meth:`VoxelMap.integrate`), with the sensor's pose in the map: first the voxels the new rays
passed through are missed (:mod:`relay.cloud.rays`; their hits drop by ``miss``, and at zero they are gone), then every
voxel a point fell in is hit once (up to ``max_hits``: a wall seen for minutes outlasts a few misses, a person seen
once goes at the first ray through them). Only voxels within twice ``voxel / resolution`` of the sensor (12.5 m at the
defaults) can be cleared: farther, a bin of the range image is wider than two voxels. A voxel takes the colour of its
latest sighting that had one.

**Versions**: the map's version grows by one with every integration that changed what a client would draw (a voxel
added or removed; a colour that changes alone goes out with the block's next change); each block keeps the version
of its last such change, so :meth:`VoxelMap.changed_since` returns
what a client at an older version lacks. A block that lost its last voxel (cleared, or dropped by the budget) is
returned empty, so that the client drops it too, for as long as the map remembers it (:data:`FORGOTTEN`); a client
older than that is told to start over (``reset``) with the whole map.

**Budget**: past ``budget_blocks`` blocks, the least recently seen are dropped first. A voxel costs 21 bytes (key 8,
time 8, colour 3, hits 1, coloured 1); a block of surface holds a few hundred.

Not thread-safe: one worker (off the event loop) owns a map. Times are the caller's (seconds), never read here.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from . import map_file
from .rays import Columns, RangeImage
from .voxel_keys import (
    LOCAL_BITS,
    block_indices,
    block_keys,
    concatenated_ranges,
    in_range,
    local_indices,
    ranges_of,
    voxel_indices,
    voxel_keys,
)

#: Removed blocks the map remembers (to tell clients to drop them) beyond its budget's worth.
FORGOTTEN: Final = 4096
_EMPTY_KEYS = np.zeros(0, dtype=np.int64)


@dataclass(frozen=True, slots=True)
class Block:
    """A block as a client draws it: its index (block coordinates), version, and its voxels' local indices (n, 3),
    colours (n, 3) and whether each colour was seen (else the client colours it by height). Empty: removed."""

    index: tuple[int, int, int]
    version: int
    local: NDArray[np.uint8]
    rgb: NDArray[np.uint8]
    coloured: NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class Changes:
    """What a client at some version lacks: ``blocks`` changed since (empty ones removed), the map's ``version`` now
    (the client's next one), and ``reset`` when the client must first drop everything it holds."""

    version: int
    reset: bool
    blocks: tuple[Block, ...]


@dataclass(frozen=True, slots=True)
class Integration:
    """What one cloud did: voxels ``added`` and ``cleared``, blocks ``dropped`` by the budget, points ``outside`` the
    keys' reach, and the map's version after it."""

    added: int
    cleared: int
    dropped: int
    outside: int
    version: int


class VoxelMap:
    """Occupied voxels of ``voxel`` metres, at most ``budget_blocks`` blocks of 16³ of them."""

    def __init__(
        self,
        voxel: float = 0.05,
        budget_blocks: int = 20_000,
        *,
        max_hits: int = 8,
        miss: int = 1,
        # Bins of 8 mrad: 3 of a Velodyne's beams across, 4 of a Kinect's pixels. Finer (4 mrad) doubled the reach of
        # clearing (below) and the time of a fusion (bench/bench_cloud_fusion.py: median 145 ms, not 105).
        resolution: float = 0.008,
        margin_voxels: float = 2.0,
        range_margin: float = 0.02,
    ) -> None:
        if not voxel > 0 or budget_blocks < 1:
            raise ValueError(f"voxel {voxel} must be above 0 and budget_blocks {budget_blocks} at least 1")
        self.voxel = float(voxel)
        self.budget_blocks = budget_blocks
        self.max_hits, self.miss = max_hits, miss
        self.resolution, self.margin, self.range_margin = resolution, margin_voxels * voxel, range_margin
        self.version = 0
        self.horizon = 0  # changes before this version are no longer known one by one
        self.keys = _EMPTY_KEYS
        self.hits = np.zeros(0, dtype=np.uint8)
        self.seen = np.zeros(0, dtype=np.float64)
        self.rgb = np.zeros((0, 3), dtype=np.uint8)
        self.coloured = np.zeros(0, dtype=np.bool_)
        self.blocks = _EMPTY_KEYS
        self.block_version = np.zeros(0, dtype=np.int64)
        self.block_seen = np.zeros(0, dtype=np.float64)
        self.removed: dict[int, int] = {}  # block key -> the version it was removed at

    def __len__(self) -> int:
        return len(self.keys)

    def integrate(
        self,
        points: NDArray[np.floating[Any]],
        pose: NDArray[np.floating[Any]],
        now: float,
        rgb: NDArray[np.uint8] | None = None,
    ) -> Integration:
        """Fuse ``points`` (N, 3) in the sensor's frame, ``pose`` (4x4) the sensor in the map at their stamp."""
        origin = np.asarray(pose, dtype=np.float64)[:3, 3]
        world, (i, j, k), inside = _placed(points, pose, self.voxel)
        outside = int(len(inside) - np.count_nonzero(inside))
        if outside:
            world = (world[0][inside], world[1][inside], world[2][inside])
            i, j, k = i[inside], j[inside], k[inside]
            rgb = None if rgb is None else rgb[inside]
        keys, first = _unique(voxel_keys(i, j, k), with_first=rgb is not None)
        changed: list[NDArray[np.int64]] = []
        gone = self._clear(RangeImage(origin, world, self.resolution), keys, changed)
        added = self._hit(keys, None if rgb is None or first is None else rgb[first], now, gone)
        if len(gone):
            self._prune_blocks(changed[0])
        if len(added):
            changed.append(np.unique(added >> LOCAL_BITS))
        self._touch_blocks(np.unique(keys >> LOCAL_BITS), now)
        dropped = self._enforce_budget(changed)
        altered = np.unique(np.concatenate(changed)) if changed else _EMPTY_KEYS
        if len(altered):
            self.version += 1
            self._mark(altered)
        return Integration(len(added), len(gone), dropped, outside, self.version)

    def changed_since(self, version: int) -> Changes:
        """The blocks a client that holds the map as of ``version`` lacks (0: a new client gets every block)."""
        reset = version < self.horizon
        since = -1 if reset else version
        fresh = self.blocks[self.block_version > since]
        blocks = list(self._views(fresh))
        if not reset and version > 0:  # a new client has nothing to drop
            gone = [(key, v) for key, v in self.removed.items() if v > since]
            blocks += [_empty_block(key, v) for key, v in sorted(gone)]
        return Changes(self.version, reset, tuple(blocks))

    def block(self, index: tuple[int, int, int]) -> Block | None:
        """The block at ``index`` (block coordinates), or None when it holds no voxel."""
        key = int(block_keys(np.array([index], dtype=np.int64))[0])
        position = int(np.searchsorted(self.blocks, key))
        if position == len(self.blocks) or self.blocks[position] != key:
            return None
        return next(self._views(self.blocks[position : position + 1]))

    def occupied(self) -> NDArray[np.int64]:
        """(N, 3) indices of every occupied voxel (its corner is index * voxel), in key order."""
        return voxel_indices(self.keys)

    def save(self, path: Path) -> None:
        """Write the map to ``path`` (.npz) atomically: a temporary file beside it, then renamed over it."""
        map_file.write(path, self._arrays())

    @classmethod
    def load(cls, path: Path, budget_blocks: int = 20_000) -> VoxelMap:
        """The map :meth:`save` wrote to ``path``; a :class:`~relay.cloud.errors.CloudError` naming the file and
        what is wrong with it otherwise."""
        arrays = map_file.read(path)
        loaded = cls(float(arrays["voxel"]), budget_blocks)
        loaded.version = loaded.horizon = int(arrays["version"])  # clients of before the restart start over
        for name in map_file.ARRAYS:
            setattr(loaded, name, arrays[name])
        return loaded

    # -- the steps of an integration --------------------------------------------------------------------------

    def _clear(self, image: RangeImage, hit: NDArray[np.int64], changed: list[Any]) -> NDArray[np.intp]:
        """Miss the map's voxels the rays passed through (not those hit now): the positions of those left without
        hits, sorted, which the same integration's rebuild removes."""
        none = np.zeros(0, dtype=np.intp)
        if not len(self.keys) or not len(hit):
            return none
        # Beyond twice voxel / resolution a bin is wider than two voxels: too coarse to say a ray went through one.
        reach = min(image.farthest, 2 * self.voxel / self.resolution)
        near = self.blocks[_blocks_within(self.blocks, self.voxel, image.origin, reach)]
        starts, ends = ranges_of(self.keys, near)
        positions = concatenated_ranges(starts, ends)
        candidates = self.keys[positions]
        centres = _centres(near, ends - starts, candidates, self.voxel)
        through = image.seen_through(centres, self.voxel, self.margin, self.range_margin)
        through[_found_in(candidates, hit)] = False
        missed = positions[through]
        if not len(missed):
            return none
        self.hits[missed] = np.maximum(self.hits[missed].astype(np.int16) - self.miss, 0).astype(np.uint8)
        gone = np.sort(missed[self.hits[missed] == 0])
        if len(gone):
            changed.append(np.unique(self.keys[gone] >> LOCAL_BITS))
        return gone

    def _hit(
        self, keys: NDArray[np.int64], rgb: NDArray[np.uint8] | None, now: float, gone: NDArray[np.intp]
    ) -> NDArray[np.int64]:
        """Hit the voxels of ``keys`` (sorted), adding those the map lacks and removing those at ``gone``, in one
        rebuild of its arrays; the keys added."""
        position = np.searchsorted(self.keys, keys)
        found = position < len(self.keys)
        found[found] = self.keys[position[found]] == keys[found]
        old = position[found]
        self.hits[old] = np.minimum(self.hits[old].astype(np.int16) + 1, self.max_hits).astype(np.uint8)
        self.seen[old] = now
        if rgb is not None:
            self.rgb[old], self.coloured[old] = rgb[found], True
        new = ~found
        colour = rgb[new] if rgb is not None else np.zeros((int(np.count_nonzero(new)), 3), np.uint8)
        added = keys[new]
        self._rebuild(gone, position[new], {"keys": added, "hits": 1, "seen": now, "rgb": colour,
                                            "coloured": rgb is not None})  # fmt: skip
        return added

    def _rebuild(self, gone: NDArray[np.intp], at: NDArray[np.intp], values: dict[str, Any]) -> None:
        """Remove the voxels at ``gone`` (sorted positions) and insert ``values`` before positions ``at`` (sorted, of
        the arrays as they are): each array copied once, where np.insert and a removal copied it twice and sorted."""
        if not len(gone) and not len(at):
            return
        keep = np.ones(len(self.keys), dtype=np.bool_)
        keep[gone] = False
        slots = at - np.searchsorted(gone, at) + np.arange(len(at))
        rest = np.ones(len(self.keys) - len(gone) + len(at), dtype=np.bool_)
        rest[slots] = False
        # One gather per array (new items' places read position 0, then overwritten): a boolean-mask scatter and
        # compress per array took three times as long.
        source = np.zeros(len(rest), dtype=np.intp)
        source[rest] = np.flatnonzero(keep)
        for name in ("keys", "hits", "seen", "rgb", "coloured"):
            old = getattr(self, name)
            merged = old.take(source, axis=0) if len(old) else np.empty((len(rest), *old.shape[1:]), old.dtype)
            if len(at):
                merged[slots] = values[name]
            setattr(self, name, merged)

    def _touch_blocks(self, touched: NDArray[np.int64], now: float) -> None:
        position = np.searchsorted(self.blocks, touched)
        found = position < len(self.blocks)
        found[found] = self.blocks[position[found]] == touched[found]
        self.block_seen[position[found]] = now
        fresh = touched[~found]
        if len(fresh):
            at = position[~found]
            self.blocks = np.insert(self.blocks, at, fresh)
            self.block_version = np.insert(self.block_version, at, 0)
            self.block_seen = np.insert(self.block_seen, at, now)
            for key in fresh.tolist():
                self.removed.pop(key, None)

    def _enforce_budget(self, changed: list[Any]) -> int:
        excess = len(self.blocks) - self.budget_blocks
        if excess <= 0:
            return 0
        oldest = np.lexsort((self.blocks, self.block_seen))[:excess]  # least recently seen, then by key
        dropped = np.sort(self.blocks[oldest])
        self._rebuild(concatenated_ranges(*ranges_of(self.keys, dropped)), np.zeros(0, np.intp), {})
        self._prune_blocks(dropped)
        changed.append(dropped)
        return excess

    def _prune_blocks(self, emptied: NDArray[np.int64]) -> None:
        """Drop the blocks among ``emptied`` (sorted keys) left without voxels, remembering them as removed."""
        starts, ends = ranges_of(self.keys, emptied)
        empty = emptied[ends == starts]
        if not len(empty):
            return
        for key in empty.tolist():
            self.removed[key] = -1  # its version is set when the integration's version is
        alive = np.ones(len(self.blocks), dtype=np.bool_)
        alive[_found_in(self.blocks, empty)] = False
        self.blocks, self.block_version = self.blocks[alive], self.block_version[alive]
        self.block_seen = self.block_seen[alive]

    def _mark(self, altered: NDArray[np.int64]) -> None:
        position = np.searchsorted(self.blocks, altered)
        found = position < len(self.blocks)
        found[found] = self.blocks[position[found]] == altered[found]
        self.block_version[position[found]] = self.version
        for key, version in list(self.removed.items()):
            if version < 0:
                self.removed[key] = self.version
        self._forget()

    def _forget(self) -> None:
        """Keep the removed blocks' memory bounded; a client older than what was forgotten starts over."""
        limit = self.budget_blocks + FORGOTTEN
        if len(self.removed) <= limit:
            return
        by_age = sorted(self.removed.items(), key=lambda item: item[1])
        for key, version in by_age[: len(self.removed) - limit]:
            del self.removed[key]
            self.horizon = max(self.horizon, version)

    # -- what leaves the map -----------------------------------------------------------------------------------

    def _views(self, keys: NDArray[np.int64]) -> Iterator[Block]:
        starts, ends = ranges_of(self.keys, keys)
        versions = self.block_version[np.searchsorted(self.blocks, keys)]
        for start, end, version, index in zip(
            starts.tolist(), ends.tolist(), versions.tolist(), block_indices(keys).tolist(), strict=True
        ):
            yield Block(
                (index[0], index[1], index[2]),
                version,
                local_indices(self.keys[start:end]),
                self.rgb[start:end],
                self.coloured[start:end],
            )

    def _arrays(self) -> dict[str, Any]:
        arrays: dict[str, Any] = {name: getattr(self, name) for name in map_file.ARRAYS}
        return {**arrays, "voxel": np.float64(self.voxel), "version": np.int64(self.version)}


def _placed(
    points: NDArray[np.floating[Any]], pose: NDArray[np.floating[Any]], voxel: float
) -> tuple[Columns, tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]], NDArray[np.bool_]]:
    """The points in the map frame and their voxel indices, by axis, and which of them keys can hold."""
    matrix = np.asarray(pose, dtype=np.float64)
    source = np.asarray(points, dtype=np.float32)
    # Column by column: (N, 3) @ (3, 3) took 48 ms for 300 000 points here, these multiply-adds 4 ms.
    x, y, z = (
        (source[:, 0] * np.float32(r[0]) + source[:, 1] * np.float32(r[1]) + source[:, 2] * np.float32(r[2]))
        + np.float32(t)
        for r, t in zip(matrix[:3, :3], matrix[:3, 3], strict=True)
    )
    scale = np.float32(1 / voxel)
    i, j, k = (np.floor(axis * scale).astype(np.int64) for axis in (x, y, z))
    return (x, y, z), (i, j, k), in_range(i, j, k)


def _blocks_within(blocks: NDArray[np.int64], voxel: float, origin: NDArray[np.float32], reach: float) -> Any:
    """Which ``blocks`` (keys) come within ``reach`` of ``origin``."""
    side = 16 * voxel
    return np.linalg.norm((block_indices(blocks) + 0.5) * side - origin, axis=1) <= reach + side


def _centres(blocks: NDArray[np.int64], counts: NDArray[np.intp], keys: NDArray[np.int64], voxel: float) -> Columns:
    """The centres of the voxels of ``keys``, by axis (float32): ``counts`` of them in each of ``blocks``, in order.
    Each block's corner repeated, plus the local index: a third of decoding every key whole."""
    size = np.float32(voxel)
    corners = (block_indices(blocks) * 16).astype(np.float32) * size
    shifts = (8, 4, 0)
    i, j, k = (
        np.repeat(corners[:, axis], counts) + (((keys >> shift) & 15).astype(np.float32) + np.float32(0.5)) * size
        for axis, shift in enumerate(shifts)
    )
    return i, j, k


def _empty_block(key: int, version: int) -> Block:
    x, y, z = block_indices(np.array([key], dtype=np.int64))[0].tolist()
    return Block((x, y, z), version, np.zeros((0, 3), np.uint8), np.zeros((0, 3), np.uint8), np.zeros(0, bool))


def _unique(keys: NDArray[np.int64], *, with_first: bool) -> tuple[NDArray[np.int64], NDArray[np.intp] | None]:
    """The sorted distinct keys, and (``with_first``) where each first occurs. A sort and a comparison: np.unique's
    hashing took 60 ms for 300 000 keys here, this 7 ms."""
    order = np.argsort(keys, kind="stable") if with_first else None
    ordered = keys[order] if order is not None else np.sort(keys)
    starts = np.ones(len(ordered), dtype=np.bool_)
    starts[1:] = ordered[1:] != ordered[:-1]
    return ordered[starts], None if order is None else order[starts]


def _found_in(sorted_keys: NDArray[np.int64], keys: NDArray[np.int64]) -> NDArray[np.intp]:
    """Where those of ``keys`` that ``sorted_keys`` holds are in it."""
    position = np.searchsorted(sorted_keys, keys)
    inside = position < len(sorted_keys)
    position = position[inside]
    found: NDArray[np.intp] = position[sorted_keys[position] == keys[inside]]
    return found
