"""PCD files (PCL's Point Cloud Data, v0.7): enough of a reader for the shared real clouds, numpy only.

``DATA ascii``, ``binary`` (points one after the other, little-endian) and ``binary_compressed`` (the shared Kinect
frames: a 4-byte compressed size, a 4-byte raw size, then LZF-compressed bytes holding each field's values for every
point, one field after the other). :func:`read_pcd` returns every point, NaN ones too, so an organized cloud keeps
its pixel order (``width`` x ``height``). Blocking file I/O: tests and tools, not the event loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Final

import numpy as np
from numpy.typing import NDArray

from .errors import CloudError, shown
from .pointcloud2 import Cloud, unpack_rgb

#: PCD's TYPE letter and SIZE to a numpy type (the files are little-endian).
_TYPES: Final = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "u1", ("U", 2): "<u2", ("U", 4): "<u4",
                 ("I", 1): "i1", ("I", 2): "<i2", ("I", 4): "<i4"}  # fmt: skip
_HEADER_LINES: Final = 20


@dataclass(frozen=True, slots=True)
class PcdFile:
    """Every point of a PCD file as a structured array (one named column per field), in the file's order."""

    points: NDArray[np.void]
    width: int
    height: int

    def cloud(self) -> Cloud:
        """The finite points, with ``intensity`` and packed ``rgb``/``rgba`` colour when the file has them."""
        xyz = np.stack([self.points[a].astype(np.float32) for a in "xyz"], axis=1)
        keep = np.isfinite(xyz).all(axis=1)
        names = self.points.dtype.names or ()
        intensity = self.points["intensity"].astype(np.float32)[keep] if "intensity" in names else None
        colour = next((n for n in ("rgb", "rgba") if n in names), None)
        rgb = unpack_rgb(self.points[colour].view("<u4")[keep]) if colour else None
        return Cloud(xyz[keep], intensity, rgb)

    def xyz(self) -> NDArray[np.float32]:
        """(width*height, 3) float32, NaN rows kept (an organized cloud's missing pixels)."""
        return np.stack([self.points[a].astype(np.float32) for a in "xyz"], axis=1)


def read_pcd(path: Path) -> PcdFile:
    """The PCD file at ``path``; a :class:`CloudError` naming the file for what this reader cannot read."""
    raw = Path(path).read_bytes()
    header: dict[str, list[str]] = {}
    position = 0
    for _ in range(_HEADER_LINES):
        end = raw.index(b"\n", position)
        line = raw[position:end].decode("ascii", "replace").strip()
        position = end + 1
        if not line or line.startswith("#"):
            continue
        key, *values = line.split()
        header[key.upper()] = values
        if key.upper() == "DATA":
            break
    else:
        raise CloudError(f"{path}: no DATA line in the first {_HEADER_LINES} lines")
    try:
        names = header["FIELDS"]
        sizes = [int(v) for v in header["SIZE"]]
        types = header["TYPE"]
        counts = [int(v) for v in header.get("COUNT", ["1"] * len(names))]
        width, height = int(header["WIDTH"][0]), int(header["HEIGHT"][0])
        kind = header["DATA"][0]
    except (KeyError, IndexError, ValueError) as exc:
        raise CloudError(f"{path}: PCD header incomplete ({exc})") from exc
    formats = []
    for name, size, letter, count in zip(names, sizes, types, counts, strict=True):
        if (letter, size) not in _TYPES or count != 1:
            raise CloudError(f"{path}: field {shown(name)} of TYPE {letter} SIZE {size} COUNT {count} not read")
        formats.append(_TYPES[(letter, size)])
    dtype = np.dtype({"names": names, "formats": formats})
    total = width * height
    body = raw[position:]
    if kind == "ascii":
        table = np.loadtxt(body.decode("ascii").splitlines(), dtype=np.float64, ndmin=2)
        points = np.zeros(total, dtype=dtype)
        for column, name in enumerate(names):
            points[name] = table[:total, column]
    elif kind == "binary":
        points = np.frombuffer(body, dtype=dtype, count=total).copy()
    elif kind == "binary_compressed":
        points = _columns(body, dtype, total, path)
    else:
        raise CloudError(f"{path}: DATA {shown(kind)} not read")
    return PcdFile(points, width, height)


def _columns(body: bytes, dtype: np.dtype[np.void], total: int, path: Path) -> NDArray[np.void]:
    """binary_compressed: LZF, then each field's values for all points, field after field."""
    compressed, size = np.frombuffer(body[:8], dtype="<u4")
    plain = lzf_decompress(body[8 : 8 + int(compressed)], int(size))
    points = np.zeros(total, dtype=dtype)
    start = 0
    for name in dtype.names or ():
        field = dtype.fields[name][0] if dtype.fields else dtype
        length = field.itemsize * total
        if start + length > len(plain):
            raise CloudError(f"{path}: compressed data ends in field {shown(name)}")
        points[name] = np.frombuffer(plain, dtype=field, count=total, offset=start)
        start += length
    return points


def lzf_decompress(data: bytes, size: int) -> bytes:
    """LibLZF's format: a control byte below 32 starts a run of that many plus one literal bytes; any other is a
    back-reference (length in its top 3 bits, 7 meaning a length byte follows; offset from its low 5 bits and the
    next byte). Loops per token, not per byte: a run or a non-overlapping copy is one slice."""
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        control = data[i]
        i += 1
        if control < 32:
            out += data[i : i + control + 1]
            i += control + 1
            continue
        length = control >> 5
        if length == 7:
            length += data[i]
            i += 1
        start = len(out) - ((control & 0x1F) << 8) - data[i] - 1
        i += 1
        length += 2
        if start < 0:
            raise CloudError("LZF back-reference before the start of the data")
        if start + length <= len(out):
            out += out[start : start + length]
        else:  # overlapping: the copy repeats the bytes it has just written
            for k in range(length):
                out.append(out[start + k])
    if len(out) != size:
        raise CloudError(f"LZF data holds {len(out)} bytes, the header says {size}")
    return bytes(out)
