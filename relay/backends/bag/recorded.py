"""What every backend that plays a recording shares (a rosbag2 recording, a recorded station session): the rate and
start checked, playback commands handed to the player, and nothing that would move a robot reaching one."""

from __future__ import annotations

import math
from collections.abc import Callable

from ...config import FleetConfig
from ...errors import BackendUnavailable, CommandRejected
from ...fleet.events import EventSink
from ...session.protocol import MAX_PLAYBACK_RATE, MIN_PLAYBACK_RATE, ErrorCode
from ..base import Backend
from .player import Player


class RecordedFleet(Backend):
    """A fleet played from a recording; ``what`` names it in messages ("the recordings", "the session")."""

    def __init__(self, config: FleetConfig, sink: EventSink, *, rate: float, start: float, what: str) -> None:
        """Check the rate and start position (cheap); the subclass opens the recording in ``start()``."""
        super().__init__(config, sink)
        if not (math.isfinite(rate) and MIN_PLAYBACK_RATE <= rate <= MAX_PLAYBACK_RATE):
            raise BackendUnavailable(
                f"--rate {rate:g}: expected a speed factor from {MIN_PLAYBACK_RATE:g} to {MAX_PLAYBACK_RATE:g}"
            )
        if not (math.isfinite(start) and start >= 0):
            raise BackendUnavailable(f"--start {start:g}: expected seconds from the start of {what}, >= 0")
        self.what = what
        self._player: Player | None = None

    # -- commands: a recording cannot be commanded (the subclass's command_refusal says why) ------

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        """Nothing to drive: only stop paths (deadman, estop, shutdown) get here, and a recording is stopped."""

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        """Never reached for goals (command_refusal refuses them all); a no-op."""

    async def cancel(self, robot: str) -> None:
        """Only stop paths get here; a recording has no goal to cancel."""

    # -- playback ---------------------------------------------------------------------------------

    async def playback(self, action: str, value: float | None) -> None:
        """Pause, resume, seek (``value`` s from the start, clamped) or set the rate (``value``)."""
        if self._player is None:
            raise CommandRejected(ErrorCode.INTERNAL, f"{self.what}: not open yet")
        self._player.command(action, value)
