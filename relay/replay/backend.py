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
from pathlib import Path

from ..backends.bag.cameras import BagCameras
from ..backends.bag.clock import PlaybackClock
from ..backends.bag.player import Player
from ..backends.bag.recorded import RecordedFleet
from ..cli.options import ReplayOptions
from ..config import FleetConfig
from ..errors import BackendUnavailable
from ..fleet.events import EventSink
from .reader import SessionReader

logger = logging.getLogger(__name__)


class ReplayBackend(RecordedFleet):
    """Replays a session recording as the robots of robots.yaml. Everything here runs on the event loop."""

    name = "replay"

    def __init__(self, config: FleetConfig, sink: EventSink, options: ReplayOptions) -> None:
        """Check the arguments (cheap); the file is opened in :meth:`start`."""
        super().__init__(config, sink, rate=options.rate, start=options.start, what="the session")
        if options.session is None:
            raise BackendUnavailable("the replay backend needs a session recording: xr-relay replay FILE")
        self.options = options
        self.path = Path(options.session)
        self._reader: SessionReader | None = None
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

    def health(self) -> dict[str, object]:
        if self._player is None:
            return {}
        return {
            "playback": self._player.health(),
            "session": {"name": self.path.name, "robots": sorted(self._robots)},
        }
