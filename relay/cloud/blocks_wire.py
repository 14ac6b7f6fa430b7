"""A voxel map's changed blocks as binary records for browsers (docs/protocol.md, "Voxel map blocks").

A record is a 28-byte header, then each voxel's local index within its block (12 bits: x * 256 + y * 16 + z, in a
little-endian uint16), then, when its flags have :data:`COLOURED`, each voxel's colour (RGB565, little-endian uint16):
2 or 4 bytes a voxel, where a raw PointCloud2 spends 16 or more on each of the several points a voxel holds. A block
whose cloud gave no colour has none: the client colours it by height with the ramp of :func:`height_colours` (its own
menu may switch to another); in a block with colours, a voxel without one is sent that ramp's colour. A record with no
voxels removes the block. Several
records may follow one another in a frame. Little-endian so that a browser views the arrays in place (every
platform's typed arrays are little-endian); both arrays start at even offsets. The first byte, ``X`` of the magic,
tells a record from a camera frame, whose first byte (of a big-endian header length under 16 MiB) is 0.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from .errors import CloudError
from .voxels import Block

#: A record's first four bytes, and the version of its layout.
MAGIC: Final = b"XRVB"
VERSION: Final = 1
#: magic, version, flags (0), voxel count, block index x/y/z, block version, voxel size (m).
HEADER: Final = struct.Struct("<4sBBH3iIf")
#: Flags: colours follow the local indices.
COLOURED: Final = 1
#: The heights (m, map frame) the ramp of :func:`height_colours` spans, and its colours, low to high.
HEIGHT_RANGE: Final = (0.0, 3.0)
RAMP: Final = np.array([[0, 0, 255], [0, 255, 255], [0, 255, 0], [255, 255, 0], [255, 0, 0]], dtype=np.float64)


@dataclass(frozen=True, slots=True)
class WireBlock:
    """A decoded record: block index, version, voxel size, local indices (n, 3) uint8 and colours (n, 3) uint8
    (each channel as RGB565 kept it; None: the block has none, the client colours it by height)."""

    index: tuple[int, int, int]
    version: int
    voxel: float
    local: NDArray[np.uint8]
    rgb: NDArray[np.uint8] | None

    def centres(self) -> NDArray[np.float64]:
        """(n, 3) voxel centres in the map frame, metres."""
        corner = np.array(self.index, dtype=np.float64) * 16
        return (corner + self.local.astype(np.float64) + 0.5) * self.voxel


def encode_blocks(blocks: Iterable[Block], voxel: float, heights: tuple[float, float] = HEIGHT_RANGE) -> bytes:
    """The records of ``blocks`` (a :class:`~relay.cloud.voxels.Changes`' blocks), one after the other."""
    return b"".join(encode_block(block, voxel, heights) for block in blocks)


def encode_block(block: Block, voxel: float, heights: tuple[float, float] = HEIGHT_RANGE) -> bytes:
    """One block's record."""
    local = block.local.astype(np.uint16)
    packed = (local[:, 0] << 8) | (local[:, 1] << 4) | local[:, 2]
    head = HEADER.pack(MAGIC, VERSION, COLOURED if block.coloured.any() else 0, len(local), *block.index,
                       block.version, voxel)  # fmt: skip
    if not block.coloured.any():
        return head + packed.astype("<u2").tobytes()
    rgb = block.rgb.copy()
    if not block.coloured.all():
        z = (block.index[2] * 16 + local[:, 2].astype(np.float64) + 0.5) * voxel
        rgb[~block.coloured] = height_colours(z[~block.coloured], heights)
    return head + packed.astype("<u2").tobytes() + rgb565(rgb).astype("<u2").tobytes()


def decode_blocks(data: bytes) -> list[WireBlock]:
    """The records of a frame (for tests and tools; the browser reads the same layout)."""
    blocks = []
    offset = 0
    while offset < len(data):
        if len(data) - offset < HEADER.size:
            raise CloudError(f"voxel block record at byte {offset}: {len(data) - offset} bytes, the header is 28")
        magic, version, flags, count, x, y, z, block_version, voxel = HEADER.unpack_from(data, offset)
        if magic != MAGIC or version != VERSION:
            raise CloudError(f"voxel block record at byte {offset}: magic {magic!r} version {version}")
        start = offset + HEADER.size
        coloured = bool(flags & COLOURED)
        end = start + (4 if coloured else 2) * count
        if end > len(data):
            raise CloudError(f"voxel block record at byte {offset}: {count} voxels need {end - offset} bytes")
        packed = np.frombuffer(data, dtype="<u2", count=count, offset=start)
        local = np.stack([(packed >> 8) & 15, (packed >> 4) & 15, packed & 15], axis=1).astype(np.uint8)
        rgb = None
        if coloured:
            rgb = from_rgb565(np.frombuffer(data, dtype="<u2", count=count, offset=start + 2 * count))
        blocks.append(WireBlock((x, y, z), block_version, voxel, local, rgb))
        offset = end
    return blocks


def rgb565(rgb: NDArray[np.uint8]) -> NDArray[np.uint16]:
    """(n,) RGB565 words of (n, 3) 8-bit colours: the top 5, 6 and 5 bits."""
    c = rgb.astype(np.uint16)
    return (((c[:, 0] >> 3) << 11) | ((c[:, 1] >> 2) << 5) | (c[:, 2] >> 3)).astype(np.uint16)


def from_rgb565(words: NDArray[np.uint16]) -> NDArray[np.uint8]:
    """(n, 3) 8-bit colours of RGB565 words, each channel's top bits repeated into its low ones (31 -> 255)."""
    w = words.astype(np.uint16)
    r, g, b = (w >> 11) & 31, (w >> 5) & 63, w & 31
    return np.stack([(r << 3) | (r >> 2), (g << 2) | (g >> 4), (b << 3) | (b >> 2)], axis=1).astype(np.uint8)


def height_colours(z: NDArray[np.float64], heights: tuple[float, float] = HEIGHT_RANGE) -> NDArray[np.uint8]:
    """(n, 3) colours of heights ``z`` (m): blue at ``heights[0]`` and below, through cyan, green and yellow, to red
    at ``heights[1]`` and above."""
    low, high = heights
    at = np.clip((np.asarray(z, dtype=np.float64) - low) / (high - low), 0.0, 1.0) * (len(RAMP) - 1)
    stops = np.arange(len(RAMP))
    channels = [np.interp(at, stops, RAMP[:, channel]) for channel in range(3)]
    return np.rint(np.stack(channels, axis=1)).astype(np.uint8)
