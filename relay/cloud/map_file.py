"""A voxel map's file (numpy .npz, no pickles): written atomically, read back with every array checked.

The relay keeps the map beside its database so that it survives a restart. The file is written to a temporary name
in the same folder, flushed to disk, then renamed over the old one: a crash mid-write leaves the old map whole. A
file that is not such a map (truncated, another .npz, arrays of the wrong kind or length) is a
:class:`~relay.cloud.errors.CloudError` naming the file and what is wrong; a missing file is the caller's (``OSError``).
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any, Final

import numpy as np

from ..atomic_file import write_atomically
from .errors import CloudError

#: The file's format; another is refused rather than misread.
FORMAT: Final = 1
#: The map's arrays, each with its dtype and trailing shape; voxel arrays share their length, block arrays theirs.
ARRAYS: Final[dict[str, tuple[str, tuple[int, ...]]]] = {
    "keys": ("int64", ()),
    "hits": ("uint8", ()),
    "seen": ("float64", ()),
    "rgb": ("uint8", (3,)),
    "coloured": ("bool", ()),
    "blocks": ("int64", ()),
    "block_version": ("int64", ()),
    "block_seen": ("float64", ()),
}
_BLOCK_ARRAYS: Final = ("blocks", "block_version", "block_seen")


def write(path: Path, arrays: dict[str, Any]) -> None:
    """Write ``arrays`` (:data:`ARRAYS`, ``voxel``, ``version``) to ``path`` atomically."""
    write_atomically(Path(path), lambda out: np.savez(out, format=np.int64(FORMAT), **arrays))


def read(path: Path) -> dict[str, Any]:
    """The arrays :func:`write` wrote to ``path``, checked."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
    except (zipfile.BadZipFile, ValueError, EOFError) as exc:
        raise CloudError(f"voxel map {path} is not a readable .npz file ({exc})") from exc
    missing = [name for name in (*ARRAYS, "voxel", "version", "format") if name not in arrays]
    if missing:
        raise CloudError(f"voxel map {path} lacks {', '.join(missing)}")
    if int(arrays["format"]) != FORMAT:
        raise CloudError(f"voxel map {path} is of format {int(arrays['format'])}, this relay reads {FORMAT}")
    if not float(arrays["voxel"]) > 0:
        raise CloudError(f"voxel map {path} has voxel size {float(arrays['voxel'])}")
    for name, (dtype, shape) in ARRAYS.items():
        value = arrays[name]
        same = len(arrays["blocks" if name in _BLOCK_ARRAYS else "keys"])
        if value.dtype != np.dtype(dtype) or value.shape != (same, *shape):
            raise CloudError(f"voxel map {path}: {name} is {value.dtype} {value.shape}, expected {dtype} ({same}, ...)")
    if (np.diff(arrays["keys"]) <= 0).any() or (np.diff(arrays["blocks"]) <= 0).any():
        raise CloudError(f"voxel map {path}: keys are not in order")
    return arrays
