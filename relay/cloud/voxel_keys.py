"""Voxel and block indices packed into one sortable int64, so that a map is a few sorted arrays.

A voxel's integer index ``(i, j, k)`` (its corner at ``(i, j, k) * voxel`` in the map frame) lies in block
``(i, j, k) >> 4`` (16 voxels a side; the shift floors negative indices too) at local ``(i, j, k) & 15``. A block's
key packs its three indices, each biased by 2**16, in 17 bits each; a voxel's key is its block's key shifted left by
12 bits, then its local index (x * 256 + y * 16 + z). Sorting voxel keys therefore groups each block's voxels
together, in block order. Blocks reach +-65536 a side: +-52 km at 5 cm voxels.
"""

from __future__ import annotations

from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

#: Voxels a block has along each side, and the bits of a voxel's local index.
BLOCK_SIDE: Final = 16
LOCAL_BITS: Final = 12
_AXIS_BITS: Final = 17
_BIAS: Final = 1 << 16
_MASK: Final = (1 << _AXIS_BITS) - 1

Keys = NDArray[np.int64]
Indices = NDArray[np.int64]


Column = NDArray[np.int64]


def in_range(i: Column, j: Column, k: Column) -> NDArray[np.bool_]:
    """Which voxels (their indices by axis) lie in blocks a key can hold."""
    low, high = -_BIAS * BLOCK_SIDE, _BIAS * BLOCK_SIDE
    inside = np.ones(len(i), dtype=np.bool_)
    for axis in (i, j, k):
        if len(axis) and (axis.min() < low or axis.max() >= high):
            inside &= (axis >= low) & (axis < high)
    return inside


def voxel_keys(i: Column, j: Column, k: Column) -> Keys:
    """The keys of voxels given their indices by axis (each within :func:`in_range`): whole columns, not (N, 3)
    rows, which numpy walks several times slower."""
    keys: Keys = ((i >> 4) + _BIAS) << (2 * _AXIS_BITS + LOCAL_BITS)
    keys |= ((j >> 4) + _BIAS) << (_AXIS_BITS + LOCAL_BITS)
    keys |= ((k >> 4) + _BIAS) << LOCAL_BITS
    keys |= ((i & 15) << 8) | ((j & 15) << 4) | (k & 15)
    return keys


def block_keys(blocks: Indices) -> Keys:
    """The keys of (N, 3) block indices."""
    b = blocks + _BIAS
    keys: Keys = (b[:, 0] << (2 * _AXIS_BITS)) | (b[:, 1] << _AXIS_BITS) | b[:, 2]
    return keys


def block_indices(keys: Keys) -> Indices:
    """(N, 3) block indices of block keys."""
    k = np.asarray(keys, dtype=np.int64)
    return np.stack([(k >> (2 * _AXIS_BITS)) & _MASK, (k >> _AXIS_BITS) & _MASK, k & _MASK], axis=1) - _BIAS


def local_indices(keys: Keys) -> NDArray[np.uint8]:
    """(N, 3) uint8 voxel indices within their blocks, of voxel keys."""
    k = np.asarray(keys, dtype=np.int64)
    return np.stack([(k >> 8) & 15, (k >> 4) & 15, k & 15], axis=1).astype(np.uint8)


def voxel_indices(keys: Keys) -> Indices:
    """(N, 3) voxel indices of voxel keys."""
    return np.stack(voxel_columns(keys), axis=1)


def voxel_columns(keys: Keys) -> tuple[Column, Column, Column]:
    """The voxel indices of voxel keys, by axis."""
    k = np.asarray(keys, dtype=np.int64)
    i = ((((k >> (2 * _AXIS_BITS + LOCAL_BITS)) & _MASK) - _BIAS) << 4) | ((k >> 8) & 15)
    j = ((((k >> (_AXIS_BITS + LOCAL_BITS)) & _MASK) - _BIAS) << 4) | ((k >> 4) & 15)
    z = ((((k >> LOCAL_BITS) & _MASK) - _BIAS) << 4) | (k & 15)
    return i, j, z


def ranges_of(sorted_keys: Keys, blocks: Keys) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(starts, ends): where each block's voxels lie in a sorted array of voxel keys."""
    starts = np.searchsorted(sorted_keys, blocks << LOCAL_BITS)
    ends = np.searchsorted(sorted_keys, (blocks + 1) << LOCAL_BITS)
    return starts, ends


def concatenated_ranges(starts: NDArray[Any], ends: NDArray[Any]) -> NDArray[np.intp]:
    """Every position in ``[start, end)`` of each range, in order, without a Python loop per range."""
    lengths = (ends - starts).astype(np.intp)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.intp)
    offsets = np.repeat(starts.astype(np.intp) - np.cumsum(lengths) + lengths, lengths)
    positions: NDArray[np.intp] = np.arange(total, dtype=np.intp) + offsets
    return positions
