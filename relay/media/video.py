"""Live video: one H.264 encoder per camera (PyAV, FFmpeg's libx264 from the wheel), whatever the number of viewers.

JPEG frames cost ~166 kB per 1280x720 image, ~40 Mbit/s per camera at 30 fps: more than a headset's Wi-Fi and a
remote site's uplink can carry. A video codec sends the difference between frames. The encoder here is set for
latency, not for size: ``tune=zerolatency`` (no lookahead, no frame threads: a frame in, its packet out),
constrained baseline (no B-frames, decodable by every WebCodecs and hardware decoder), a keyframe every
:data:`GOP_SECONDS` and whenever asked (a viewer that joined or lost frames: :meth:`H264Encoder.encode` with
``keyframe=True``), the bitrate capped by an HRD buffer of half a second so that a burst never queues seconds of
video in a socket. Packets are Annex B (start codes, SPS and PPS in front of every keyframe), so a decoder needs no
out-of-band description: WebCodecs decodes Annex B when its config has no ``description``, and the header of each
binary frame says the codec string (``avc1.PPCCLL`` read from the stream's SPS) and whether the packet is a
keyframe.

Pure apart from PyAV: no threads, no loop. relay/media/video_streams.py runs these encoders on a pool, one encode of a
camera at a time, and hands packets to the hub.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

logger = logging.getLogger(__name__)

#: Seconds between two keyframes when nobody asks for one (a viewer that joins waits at most this long without
#: asking; the relay asks, so in practice one frame).
GOP_SECONDS = 1.0
#: Default bitrate per camera at 1280x720 and 30 fps; other sizes and rates scale with pixels per second.
DEFAULT_BITRATE_720P30 = 2_500_000
#: x264's speed/quality trade-off: "veryfast" keeps 720p30 under a quarter of a core here (docs/benchmarks.md)
#: with SSIM above 0.95 at 2.5 Mbit/s; "ultrafast" halves the time but loses ~0.02 SSIM at the same rate.
PRESET = "veryfast"


class VideoError(ValueError):
    """An image that cannot become video (odd size, wrong shape): the message names the camera's problem."""


def default_bitrate(width: int, height: int, fps: float) -> int:
    """2.5 Mbit/s at 720p30, scaled by pixels per second, never under 200 kbit/s."""
    scale = (width * height * max(fps, 1.0)) / (1280 * 720 * 30)
    return max(200_000, int(DEFAULT_BITRATE_720P30 * scale))


@dataclass(frozen=True, slots=True)
class Packet:
    """One encoded picture: Annex B bytes, whether a decoder may start here, the codec string for WebCodecs."""

    data: bytes
    keyframe: bool
    codec: str
    width: int
    height: int


def codec_string(annexb: bytes) -> str | None:
    """``avc1.PPCCLL`` from the first SPS (NAL type 7) of an Annex B packet: profile, constraint flags, level."""
    i = 0
    while True:
        i = annexb.find(b"\x00\x00\x01", i)
        if i < 0 or i + 6 >= len(annexb):
            return None
        nal = annexb[i + 3]
        if nal & 0x1F == 7:
            profile, constraints, level = annexb[i + 4], annexb[i + 5], annexb[i + 6]
            return f"avc1.{profile:02X}{constraints:02X}{level:02X}"
        i += 3


class H264Encoder:
    """One camera's encoder. Frames must keep the size it was made for (a new size needs a new encoder)."""

    def __init__(self, width: int, height: int, fps: float, bitrate: int | None = None) -> None:
        if width <= 0 or height <= 0 or width % 2 or height % 2:
            raise VideoError(f"{width}x{height} cannot be H.264 video: 4:2:0 needs an even width and height")
        import av  # imported here: the relay starts without touching FFmpeg until a client asks for video

        self.width, self.height = width, height
        self.fps = max(1.0, float(fps))
        self.bitrate = bitrate if bitrate is not None else default_bitrate(width, height, self.fps)
        #: The rate it was opened with: the HRD cap (maxrate); :meth:`set_bitrate` moves the target under it.
        self.configured = self.bitrate
        context: Any = av.CodecContext.create("libx264", "w")
        context.width, context.height = width, height
        context.pix_fmt = "yuv420p"
        context.time_base = Fraction(1, 1000)  # pts in milliseconds of the frames' stamps
        context.framerate = Fraction(round(self.fps * 1000), 1000)
        context.bit_rate = self.bitrate
        context.gop_size = max(1, round(self.fps * GOP_SECONDS))
        context.max_b_frames = 0
        context.thread_count = 1  # one camera, one core at most; the pool runs cameras side by side
        context.options = {
            "preset": PRESET,
            "tune": "zerolatency",
            "profile": "baseline",
            "forced-idr": "1",  # a keyframe asked for is an IDR: a decoder can start there
            "maxrate": str(self.bitrate),
            "bufsize": str(self.bitrate // 2),  # half a second of HRD buffer: bursts stay short
            "x264-params": "repeat-headers=1:aud=0",  # SPS/PPS in front of every keyframe (Annex B in-band)
        }
        context.open()
        self._av = av
        self._context = context
        self._codec: str | None = None
        self._first_stamp: float | None = None
        self._last_pts = -1
        self.frames = 0

    def encode(self, bgr: NDArray[np.uint8], stamp: float, *, keyframe: bool = False) -> list[Packet]:
        """Encode one BGR image (``stamp`` in seconds, for the timestamps); ``keyframe`` forces an IDR."""
        if bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.shape[0] != self.height or bgr.shape[1] != self.width:
            raise VideoError(f"an image of shape {bgr.shape} does not fit a {self.width}x{self.height} video stream")
        # OpenCV's conversion to I420 rather than FFmpeg's swscale inside PyAV: quicker here, and one copy.
        yuv = np.asarray(cv2.cvtColor(np.ascontiguousarray(bgr), cv2.COLOR_BGR2YUV_I420), dtype=np.uint8)
        frame = self._av.VideoFrame.from_ndarray(yuv, format="yuv420p")
        if self._first_stamp is None:
            self._first_stamp = stamp
        pts = max(self._last_pts + 1, round((stamp - self._first_stamp) * 1000))
        self._last_pts = pts
        frame.pts = pts
        frame.time_base = Fraction(1, 1000)
        if keyframe:
            frame.pict_type = self._av.video.frame.PictureType.I
        self.frames += 1
        return [self._packet(p) for p in self._context.encode(frame)]

    def set_bitrate(self, bitrate: int) -> None:
        """A new target (bit/s), at most the one it was opened with; FFmpeg's libx264 wrapper reconfigures x264
        before the next frame when the context's bit_rate changed."""
        self.bitrate = max(50_000, min(self.configured, int(bitrate)))
        self._context.bit_rate = self.bitrate

    def _packet(self, packet: Any) -> Packet:
        data = bytes(packet)
        if packet.is_keyframe and self._codec is None:
            self._codec = codec_string(data)
        return Packet(data, bool(packet.is_keyframe), self._codec or "avc1.42E01F", self.width, self.height)

    def close(self) -> None:
        """Flush and free the encoder (its delayed packets, none with zerolatency, are dropped)."""
        try:
            self._context.encode(None)
        except Exception as exc:  # an encoder that never got a frame; nothing to flush
            logger.debug("h264 flush: %s", exc)
