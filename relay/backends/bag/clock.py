"""The playback clock: where a replay is, at which rate, paused or not, on the event loop's clock."""

from __future__ import annotations

import logging
from collections.abc import Callable

logger = logging.getLogger(__name__)


class PlaybackClock:
    """Where playback is, in seconds from the recordings' start, as a function of a monotonic clock.

    Contract: ``0 <= position() <= duration``. While playing, the position advances ``rate`` seconds per
    second of ``now()``; pause, resume, seek and rate changes re-anchor it, so it only jumps at seeks.
    """

    def __init__(self, now: Callable[[], float], duration: float, rate: float, start: float) -> None:
        self._now = now
        self.duration = max(0.0, duration)
        self.rate = rate
        self.paused = False
        self._anchor_position = min(max(0.0, start), self.duration)
        self._anchor_time = now()

    def position(self) -> float:
        if self.paused:
            return self._anchor_position
        elapsed = (self._now() - self._anchor_time) * self.rate
        return min(self.duration, self._anchor_position + elapsed)

    def _anchor(self, position: float) -> None:
        self._anchor_position = min(max(0.0, position), self.duration)
        self._anchor_time = self._now()

    def pause(self) -> None:
        self._anchor(self.position())
        self.paused = True

    def resume(self) -> None:
        self._anchor(self.position())
        self.paused = False

    def seek(self, position: float) -> None:
        self._anchor(position)

    def set_rate(self, rate: float) -> None:
        self._anchor(self.position())
        self.rate = rate

    def wall_delay(self, position: float) -> float | None:
        """Seconds of ``now()`` until the clock reaches ``position``: 0 once it has, None while paused."""
        current = self.position()
        if position <= current:
            return 0.0
        if self.paused:
            return None
        return (position - current) / self.rate
