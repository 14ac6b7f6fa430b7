"""The ``replay`` backend: a recorded station session (``xr-relay replay FILE``) played back as the fleet.

The robots' poses, readings, navigation and paths come back as events at their recorded times, on the bag backend's
timeline (relay/backends/bag/: :class:`~relay.backends.bag.clock.PlaybackClock` and
:class:`~relay.backends.bag.player.Player`), so a page plays it with ``playback/pause|resume|seek|rate`` as it plays
a bag. The file is read by a thread of its own (relay/replay/reader.py), ahead of playback and never whole. Nothing
reaches a robot: every command that would move one is refused (``recording``), stops have nothing to stop.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Callable
from pathlib import Path

from ..backends.bag.cameras import BagCameras
from ..backends.bag.clock import PlaybackClock
from ..backends.bag.player import Player
from ..backends.base import Backend
from ..cli.options import ReplayOptions
from ..config import FleetConfig
from ..errors import BackendUnavailable, CommandRejected
from ..fleet.events import EventSink
from ..session.protocol import MAX_PLAYBACK_RATE, MIN_PLAYBACK_RATE, ErrorCode
from .reader import SessionReader

logger = logging.getLogger(__name__)


class ReplayBackend(Backend):
    """Replays a session recording as the robots of robots.yaml. Everything here runs on the event loop."""

    name = "replay"

    def __init__(self, config: FleetConfig, sink: EventSink, options: ReplayOptions) -> None:
        """Check the arguments (cheap); the file is opened in :meth:`start`."""
        super().__init__(config, sink)
        if not (math.isfinite(options.rate) and MIN_PLAYBACK_RATE <= options.rate <= MAX_PLAYBACK_RATE):
            raise BackendUnavailable(
                f"--rate {options.rate:g}: expected a speed factor from {MIN_PLAYBACK_RATE:g} to {MAX_PLAYBACK_RATE:g}"
            )
        if not (math.isfinite(options.start) and options.start >= 0):
            raise BackendUnavailable(f"--start {options.start:g}: expected seconds from the session's start, >= 0")
        if options.session is None:
            raise BackendUnavailable("the replay backend needs a session recording: xr-relay replay FILE")
        self.options = options
        self.path = Path(options.session)
        self._reader: SessionReader | None = None
        self._player: Player | None = None
        self._cameras = BagCameras(sink)  # a session holds no pictures: it stays empty
        self._robots: frozenset[str] = frozenset()

    async def start(self) -> None:
        """Open the recording (its reader thread) and start playing. Raises BackendUnavailable naming the file when it
        is not a finished session recording; nothing keeps running then."""
        loop = asyncio.get_running_loop()
        reader = SessionReader(self.path, loop)
        reader.start_thread()
        try:
            contents = await asyncio.wrap_future(reader.opened)
        except BaseException:
            await self._close(reader)
            raise
        self._reader = reader
        self._robots = contents.robots & set(self.config.names)
        unknown = sorted(contents.robots - self._robots)
        if unknown:
            logger.warning("%s: robots not in the fleet's config, left out: %s", self.path, ", ".join(unknown))
        offline = [r for r in self.config.names if r not in self._robots]
        if offline:
            logger.info("not in the session, offline: %s", ", ".join(offline))
        start = min(self.options.start, contents.duration)
        clock = PlaybackClock(loop.time, contents.duration, self.options.rate, start)
        self._player = Player(clock, [reader], self.sink, self._cameras, loop_at_end=self.options.loop)
        reader.play(self._robots, start)
        self._player.start()
        logger.info(
            "replaying the session %s: %.1f s from %.1f s at rate %g, robots %s",
            self.path, contents.duration, start, self.options.rate, ", ".join(sorted(self._robots)) or "none",
        )  # fmt: skip

    async def stop(self) -> None:
        if self._player is not None:
            await self._player.stop()
        reader, self._reader = self._reader, None
        if reader is not None:
            await self._close(reader)
        self._cameras.close()

    @staticmethod
    async def _close(reader: SessionReader) -> None:
        reader.close()
        await asyncio.to_thread(reader.join, 2.0)

    # -- commands: a replay cannot be commanded ---------------------------------------------------

    def command_refusal(self, robot: str) -> str | None:
        return f"{robot} is a replayed session ({self.path.name}); nothing reaches a robot in a replay"

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        """Nothing to drive: only stop paths (deadman, estop, shutdown) get here."""

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        """Never reached for goals (command_refusal refuses them all)."""

    async def cancel(self, robot: str) -> None:
        """Only stop paths get here; a replay has no goal to cancel."""

    # -- playback ---------------------------------------------------------------------------------

    async def playback(self, action: str, value: float | None) -> None:
        if self._player is None:
            raise CommandRejected(ErrorCode.INTERNAL, "the session is not open yet")
        self._player.command(action, value)

    def health(self) -> dict[str, object]:
        if self._player is None:
            return {}
        return {
            "playback": self._player.health(),
            "session": {"name": self.path.name, "robots": sorted(self._robots)},
        }
