"""sensor_msgs/PointCloud2 to numpy arrays, and back (for tests and the simulator).

A message (rosbags' or rclpy's: the attribute names are the same, or :class:`PointCloud2Fields`) is read through a
structured dtype built from its ``fields`` (offsets, types, either endianness), so that no Python code runs per
point: ``xyz`` as float32, ``intensity`` when there is such a field, ``rgb`` from a packed ``rgb``/``rgba`` field
(PCL's layout: the 4 bytes as a 32-bit word ``0x00RRGGBB``, whether the field is declared FLOAT32 or UINT32). Points
with a NaN or infinite coordinate are dropped (an organized cloud marks missing returns so). A layout that cannot be
what it says (a field past ``point_step``, data shorter than its rows, no ``x``/``y``/``z``) is a
:class:`~relay.cloud.errors.CloudError` naming the field. Pure: callers run it on their own thread.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from .errors import CloudError, shown

#: sensor_msgs/PointField's datatype constants and the numpy type each stands for (its byte order added per message).
DATATYPES: Final[dict[int, str]] = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}
FLOAT32: Final = 7
FLOAT64: Final = 8
#: The most fields a cloud may declare: real drivers send a handful (Ouster's has 9); more is a malformed message.
MAX_FIELDS: Final = 64
_RGB_NAMES: Final = ("rgb", "rgba")


@dataclass(frozen=True, slots=True)
class Cloud:
    """Decoded points: ``xyz`` (N, 3) float32 in the message's frame; ``intensity`` (N,) float32 and ``rgb`` (N, 3)
    uint8 when the cloud has them."""

    xyz: NDArray[np.float32]
    intensity: NDArray[np.float32] | None = None
    rgb: NDArray[np.uint8] | None = None

    def __len__(self) -> int:
        return len(self.xyz)


@dataclass(frozen=True, slots=True)
class PointFieldSpec:
    """A sensor_msgs/PointField: ``name``, byte ``offset`` in a point, ``datatype`` (:data:`DATATYPES`), ``count``."""

    name: str
    offset: int
    datatype: int
    count: int = 1


@dataclass(frozen=True, slots=True)
class PointCloud2Fields:
    """A PointCloud2's fields without its header, as :func:`decode_pointcloud2` reads them and a message holds them."""

    fields: tuple[PointFieldSpec, ...]
    point_step: int
    row_step: int
    width: int
    height: int
    is_bigendian: bool
    is_dense: bool
    data: bytes


def decode_pointcloud2(message: Any) -> Cloud:
    """The finite points of a PointCloud2 ``message`` (anything with its fields), with intensity and colour."""
    fields = _field_table(message.fields, int(message.point_step))
    for axis in "xyz":
        if axis not in fields:
            raise CloudError(f"PointCloud2 has no {axis!r} field (it has {_names(fields)})")
    order = ">" if message.is_bigendian else "<"
    records = _records(message)
    wanted = ["x", "y", "z", "intensity", *_RGB_NAMES]
    dtype = np.dtype(
        {
            "names": [n for n in wanted if n in fields],
            "formats": [order + DATATYPES[fields[n].datatype] for n in wanted if n in fields],
            "offsets": [fields[n].offset for n in wanted if n in fields],
            "itemsize": int(message.point_step),
        }
    )
    points = records.view(dtype).reshape(-1)
    xyz = np.empty((len(points), 3), dtype=np.float32)
    for column, axis in enumerate("xyz"):
        xyz[:, column] = points[axis]
    finite = np.isfinite(xyz).all(axis=1)
    keep = None if finite.all() else finite
    intensity = points["intensity"].astype(np.float32) if "intensity" in fields else None
    rgb_name = next((n for n in _RGB_NAMES if n in fields), None)
    rgb = None
    if rgb_name is not None:
        if np.dtype(DATATYPES[fields[rgb_name].datatype]).itemsize != 4:
            raise CloudError(f"PointCloud2 field {shown(rgb_name)} is not 4 bytes (packed 0x00RRGGBB)")
        rgb = unpack_rgb(points[rgb_name].view(order + "u4"))
    if keep is not None:
        xyz = xyz[keep]
        intensity = None if intensity is None else intensity[keep]
        rgb = None if rgb is None else rgb[keep]
    return Cloud(xyz, intensity, rgb)


def unpack_rgb(packed: NDArray[np.uint32]) -> NDArray[np.uint8]:
    """(N, 3) uint8 from PCL's packed 32-bit words ``0x00RRGGBB`` (or ``0xAARRGGBB``: alpha is ignored)."""
    words = np.asarray(packed, dtype=np.uint32)
    return np.stack([(words >> 16) & 0xFF, (words >> 8) & 0xFF, words & 0xFF], axis=1).astype(np.uint8)


def pack_rgb(rgb: NDArray[np.uint8]) -> NDArray[np.uint32]:
    """PCL's packed words ``0x00RRGGBB`` of (N, 3) uint8 colours."""
    c = np.asarray(rgb, dtype=np.uint32)
    return ((c[:, 0] << 16) | (c[:, 1] << 8) | c[:, 2]).astype(np.uint32)


def encode_pointcloud2(
    xyz: NDArray[np.floating[Any]],
    rgb: NDArray[np.uint8] | None = None,
    *,
    intensity: NDArray[np.floating[Any]] | None = None,
    big_endian: bool = False,
    float64: bool = False,
    width: int | None = None,
) -> PointCloud2Fields:
    """A PointCloud2's fields holding ``xyz`` (float32, or float64), then ``intensity`` (float32) and ``rgb``
    (packed FLOAT32, as PCL and RViz write it) when given; one row unless ``width`` makes it organized."""
    points = np.asarray(xyz)
    order = ">" if big_endian else "<"
    coord = "f8" if float64 else "f4"
    specs: list[PointFieldSpec] = []
    offset = 0
    for axis in "xyz":
        specs.append(PointFieldSpec(axis, offset, FLOAT64 if float64 else FLOAT32))
        offset += 8 if float64 else 4
    names, formats = ["x", "y", "z"], [order + coord] * 3
    if intensity is not None:
        specs.append(PointFieldSpec("intensity", offset, FLOAT32))
        names, formats, offset = [*names, "intensity"], [*formats, order + "f4"], offset + 4
    if rgb is not None:
        specs.append(PointFieldSpec("rgb", offset, FLOAT32))
        names, formats, offset = [*names, "rgb"], [*formats, order + "u4"], offset + 4
    records = np.zeros(len(points), dtype=np.dtype({"names": names, "formats": formats}))
    for column, axis in enumerate("xyz"):
        records[axis] = points[:, column]
    if intensity is not None:
        records["intensity"] = intensity
    if rgb is not None:
        records["rgb"] = pack_rgb(rgb)
    row = width or len(points)
    height = len(points) // row if row else 0
    return PointCloud2Fields(
        fields=tuple(specs),
        point_step=offset,
        row_step=offset * row,
        width=row,
        height=height,
        is_bigendian=big_endian,
        is_dense=bool(np.isfinite(points).all()),
        data=records.tobytes(),
    )


def _field_table(fields: Sequence[Any], point_step: int) -> dict[str, PointFieldSpec]:
    """The message's fields by name, each checked to lie within a point."""
    if len(fields) > MAX_FIELDS:
        raise CloudError(f"PointCloud2 declares {len(fields)} fields (at most {MAX_FIELDS})")
    if point_step <= 0:
        raise CloudError(f"PointCloud2 point_step is {point_step}")
    table: dict[str, PointFieldSpec] = {}
    for field in fields:
        spec = PointFieldSpec(str(field.name), int(field.offset), int(field.datatype), int(field.count))
        if spec.datatype not in DATATYPES:
            raise CloudError(f"PointCloud2 field {shown(spec.name)} has unknown datatype {spec.datatype}")
        size = np.dtype(DATATYPES[spec.datatype]).itemsize * max(spec.count, 1)
        if spec.offset < 0 or spec.offset + size > point_step:
            raise CloudError(
                f"PointCloud2 field {shown(spec.name)} (offset {spec.offset}, {size} bytes) lies past "
                f"point_step {point_step}"
            )
        table.setdefault(spec.name, spec)
    return table


def _records(message: Any) -> NDArray[np.uint8]:
    """The points' bytes as (height*width, point_step) uint8, rows' padding (``row_step`` beyond them) left out."""
    width, height = int(message.width), int(message.height)
    point_step, row_step = int(message.point_step), int(message.row_step)
    data = np.frombuffer(memoryview(message.data).cast("B"), dtype=np.uint8)
    used = width * point_step
    if row_step < used:
        raise CloudError(f"PointCloud2 row_step {row_step} is shorter than width {width} x point_step {point_step}")
    needed = (height - 1) * row_step + used if height else 0
    if len(data) < needed:
        raise CloudError(
            f"PointCloud2 data is {len(data)} bytes, {width}x{height} points of {point_step} need {needed}"
        )
    if row_step == used:
        return data[: height * used].reshape(-1, point_step)
    rows = np.lib.stride_tricks.as_strided(data, shape=(height, used), strides=(row_step, 1))
    return np.ascontiguousarray(rows).reshape(-1, point_step)


def _names(fields: dict[str, PointFieldSpec]) -> str:
    listed = ", ".join(shown(n) for n in list(fields)[:8])
    return listed + (", ..." if len(fields) > 8 else "") if fields else "none"
