"""Laser scans for the wire, shared by the ``ros`` and ``bag`` backends.

A sensor_msgs/LaserScan (an rclpy message or a rosbags one: the fields are the same) becomes a
:class:`~relay.fleet.events.ScanEvent`: invalid returns become NaN, and a scan of more than
:data:`~relay.session.protocol.MAX_SCAN_POINTS` beams is decimated keeping the nearest return of each bin, so that
no obstacle disappears. Pure numpy, no I/O: callers run it on their own thread (the ROS executor, a bag
reader), never on the event loop. The rate limit (:data:`~relay.session.protocol.MAX_SCAN_RATE`) is the caller's, with
:class:`RateCap`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..session.protocol import MAX_SCAN_POINTS, take_frame
from .events import ScanEvent


def decimate_ranges(
    ranges: Sequence[float] | NDArray[np.floating[Any]],
    range_min: float,
    range_max: float,
    max_points: int = MAX_SCAN_POINTS,
) -> tuple[NDArray[np.float32], int]:
    """(ranges, step): at most ``max_points`` ranges, NaN where no beam of a bin saw a valid return.

    A return is valid when it is finite and within ``[range_min, range_max]``. With ``step`` > 1, output
    beam ``i`` is the nearest valid return among input beams ``i*step .. i*step+step-1`` (a trailing
    partial bin is dropped), so its angle increment is ``step`` times the input's.
    """
    values = np.asarray(ranges, dtype=np.float32)
    valid = np.isfinite(values) & (values >= range_min) & (values <= range_max)
    values = np.where(valid, values, np.float32(np.nan)).astype(np.float32)
    step = max(1, math.ceil(len(values) / max_points))
    if step == 1:
        return values, 1
    usable = len(values) // step * step
    bins = values[:usable].reshape(-1, step)
    # The nearest return of each bin: decimation must never hide an obstacle.
    nearest = np.min(np.nan_to_num(bins, nan=np.inf), axis=1)
    return np.where(np.isinf(nearest), np.float32(np.nan), nearest).astype(np.float32), step


def scan_event(robot: str, stamp: float, message: Any) -> ScanEvent:
    """The ScanEvent of one LaserScan ``message`` (rclpy or rosbags), stamped ``stamp`` by the caller."""
    ranges, step = decimate_ranges(message.ranges, float(message.range_min), float(message.range_max))
    return ScanEvent(
        robot,
        stamp,
        message.header.frame_id,
        float(message.angle_min),
        float(message.angle_increment) * step,
        float(message.range_max),
        tuple(ranges.tolist()),  # Python floats (the wire rounds them), in C rather than one by one
    )


class RateCap:
    """At most ``rate`` messages a second per key on average, without losing a stream that arrives at about that
    rate with jitter: :func:`relay.session.protocol.take_frame`'s rule, per key. "Not within 1/rate of the last one"
    dropped every scan of a 10 Hz laser that came a little early: 560 of 1000 a second reached the clients of 100
    robots (bench/bench_ros_ingest.py). Pure: the caller passes its clock."""

    def __init__(self, rate: float) -> None:
        self.rate = rate
        self._due: dict[str, float] = {}

    def allow(self, key: str, now: float) -> bool:
        after = take_frame(now, self._due.get(key, -math.inf), self.rate)
        if after is None:
            return False
        self._due[key] = after
        return True

    def clear(self) -> None:
        self._due.clear()
