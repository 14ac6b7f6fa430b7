"""Camera images to JPEG with OpenCV, for the ros and bag backends (and the simulator's camera).

These functions are CPU-heavy: callers run them in a worker thread, never on the event loop.
"""

from __future__ import annotations

import struct

import cv2
import numpy as np
from numpy.typing import NDArray

#: JPEG quality of re-encoded frames: at 80 a 640x480 camera image is ~30-60 kB, under 1/10 of raw RGB.
JPEG_QUALITY = 80

#: sensor_msgs/Image encodings the relay can convert, with their channel count and element type.
ENCODINGS: dict[str, tuple[int, type[np.generic]]] = {
    "rgb8": (3, np.uint8),
    "bgr8": (3, np.uint8),
    "rgba8": (4, np.uint8),
    "bgra8": (4, np.uint8),
    "mono8": (1, np.uint8),
    "8UC1": (1, np.uint8),
    "8UC3": (3, np.uint8),
    "mono16": (1, np.uint16),
    "16UC1": (1, np.uint16),
}


class ImageError(ValueError):
    """An image that cannot be converted; the message names what is wrong."""


def raw_to_bgr(
    data: bytes | bytearray | memoryview | NDArray[np.uint8],
    width: int,
    height: int,
    encoding: str,
    step: int,
    big_endian: bool = False,
) -> NDArray[np.uint8]:
    """A sensor_msgs/Image payload as an 8-bit BGR (or grey) array for OpenCV."""
    if encoding not in ENCODINGS:
        raise ImageError(f"unsupported image encoding {encoding!r}; supported: {', '.join(ENCODINGS)}")
    channels, dtype = ENCODINGS[encoding]
    itemsize = np.dtype(dtype).itemsize
    row = width * channels * itemsize
    if width <= 0 or height <= 0 or step < row or len(data) < step * (height - 1) + row:
        raise ImageError(f"image of {len(data)} bytes does not hold {width}x{height} {encoding} with step {step}")
    buffer = np.frombuffer(data, dtype=np.uint8, count=step * height if len(data) >= step * height else -1)
    rows = np.lib.stride_tricks.as_strided(buffer, shape=(height, row), strides=(step, 1))
    pixels = np.ascontiguousarray(rows).view(np.dtype(dtype).newbyteorder(">" if big_endian else "<"))
    pixels = pixels.reshape(height, width, channels) if channels > 1 else pixels.reshape(height, width)
    if itemsize == 2:
        # Depth and other 16-bit images: stretch their range to 8 bits (0 stays black = no data).
        peak = int(pixels.max()) or 1
        return (pixels.astype(np.float32) * (255.0 / peak)).astype(np.uint8)
    conversion = {"rgb8": cv2.COLOR_RGB2BGR, "rgba8": cv2.COLOR_RGBA2BGR, "bgra8": cv2.COLOR_BGRA2BGR}.get(encoding)
    result: NDArray[np.uint8] = pixels.astype(np.uint8, copy=False)
    return np.asarray(cv2.cvtColor(result, conversion), dtype=np.uint8) if conversion is not None else result


def encode_jpeg(image: NDArray[np.uint8], quality: int = JPEG_QUALITY) -> bytes:
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ImageError("OpenCV could not encode the image as JPEG")
    return encoded.tobytes()


def jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a JPEG's start-of-frame marker, without decoding it; None if not a JPEG."""
    if len(data) < 4 or data[:2] != b"\xff\xd8":
        return None
    index = 2
    while index + 9 < len(data):
        if data[index] != 0xFF:
            return None
        marker = data[index + 1]
        if marker == 0xFF:  # fill byte
            index += 1
            continue
        (length,) = struct.unpack_from(">H", data, index + 2)
        # SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC) carry the frame size.
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            height, width = struct.unpack_from(">HH", data, index + 5)
            return width, height
        index += 2 + length
    return None


def compressed_to_jpeg(data: bytes, fmt: str, quality: int = JPEG_QUALITY) -> tuple[bytes, int, int]:
    """A sensor_msgs/CompressedImage as (jpeg, width, height): JPEG passes through, others are re-encoded."""
    if "jpeg" in fmt.lower() or "jpg" in fmt.lower():
        size = jpeg_size(data)
        if size is not None:
            return data, size[0], size[1]
    decoded = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    image = None if decoded is None else np.asarray(decoded, dtype=np.uint8)
    if image is None:
        raise ImageError(f"compressed image ({fmt!r}, {len(data)} bytes) could not be decoded")
    return encode_jpeg(image, quality), int(image.shape[1]), int(image.shape[0])
