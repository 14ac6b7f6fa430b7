"""Playback on the loop: each recording's events handed on when the clock reaches them, the position reported, seeks,
the end of the recordings (start over or pause). The recordings are rosbag2 bags (relay/backends/bag/reader.py) or a
station session (relay/replay/reader.py): anything read ahead as a :class:`~relay.backends.bag.read_ahead.ReadAhead`
is."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Sequence
from typing import Any

from ...errors import CommandRejected
from ...fleet.events import AvatarEvent, EventSink, PlaybackEvent, PoseEvent, ScanEvent
from ...fleet.scan import RateCap
from ...session.protocol import MAX_SCAN_RATE, ErrorCode
from ..cloud_intake import CloudIntake
from .cameras import BagCameras
from .clock import PlaybackClock
from .decoding import Payload, _Cloud, _Image
from .read_ahead import ReadAhead

logger = logging.getLogger(__name__)

#: How often the playback position is reported when nothing changes (s).
PLAYBACK_REPORT_PERIOD = 1.0
#: The loop task delivering a bag's events yields to other tasks after delivering for this long (s): a replay
#: catching up at rate 20 must not hold the loop (clients' frames, estop) for more than a few milliseconds.
DELIVERY_SLICE = 0.01


async def _wait(event: asyncio.Event, delay: float | None) -> None:
    """Until ``event`` is set or ``delay`` seconds passed (a timer, not a task: this runs per event)."""
    if delay is None:
        await event.wait()
        return
    if delay <= 0:
        await asyncio.sleep(0)  # still a suspension point: callers loop on this
        return
    handle = asyncio.get_running_loop().call_later(delay, event.set)
    try:
        await event.wait()
    finally:
        handle.cancel()


class Player:
    """The opened recordings played by one clock: one task per recording and a ticker, all on the event loop."""

    def __init__(
        self,
        clock: PlaybackClock,
        readers: Sequence[ReadAhead[Any, Any]],
        sink: EventSink,
        cameras: BagCameras,
        *,
        loop_at_end: bool,
        clouds: CloudIntake | None = None,
    ) -> None:
        self.clock = clock
        self._readers = readers
        self._sink = sink
        self._cameras = cameras
        self._loop_at_end = loop_at_end
        self._clouds = clouds
        self._tasks: list[asyncio.Task[None]] = []
        self._ticker_wake = asyncio.Event()
        #: What a paused recording sends again once a second: each robot's pose and each operator's viewpoint.
        self._last: dict[tuple[str, str], PoseEvent | AvatarEvent] = {}
        self._scan_cap = RateCap(MAX_SCAN_RATE)

    def start(self) -> None:
        """Play every bag (each already told where to start), and report where playback is."""
        loop = asyncio.get_running_loop()
        for reader in self._readers:
            self._tasks.append(loop.create_task(self._play(reader), name=f"play-{reader.name}"))
        self._tasks.append(loop.create_task(self._tick(), name="bag-playback"))
        self._emit_playback()  # before any client connects: the first hello already says where playback is

    async def stop(self) -> None:
        tasks, self._tasks = self._tasks, []
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    def command(self, action: str, value: float | None) -> None:
        """Pause, resume, seek (``value`` s from the start, clamped) or set the rate (``value``)."""
        clock = self.clock
        if action == "pause":
            clock.pause()
        elif action == "resume":
            if clock.position() >= clock.duration:
                self._restart(0.0)  # play again from the start, as players do
            clock.resume()
        elif action == "seek" and value is not None:
            self._restart(min(max(0.0, value), clock.duration))
        elif action == "rate" and value is not None:
            clock.set_rate(value)
        else:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"playback/{action}: not a playback command")
        logger.info("playback %s%s", action, f" {value:g}" if value is not None else "")
        self._changed()

    def health(self) -> dict[str, object]:
        """Where the playback is, as /healthz shows it (the bag and replay backends alike)."""
        clock = self.clock
        return {
            "position": round(clock.position(), 3),
            "duration": round(clock.duration, 3),
            "rate": clock.rate,
            "paused": clock.paused,
            "loop": self._loop_at_end,
        }

    def _restart(self, position: float) -> None:
        self.clock.seek(position)
        self._scan_cap.clear()
        self._last.clear()  # the paused re-report must not resend a pose from before the seek
        self._cameras.forget_latest()
        for reader in self._readers:
            reader.restart(position)

    def _changed(self) -> None:
        """The clock changed: re-plan every delivery, and report the new state now."""
        for reader in self._readers:
            reader.ready.set()
        self._emit_playback()
        self._ticker_wake.set()

    def _emit_playback(self) -> None:
        clock = self.clock
        self._sink(PlaybackEvent(clock.position(), clock.duration, clock.rate, clock.paused, self._loop_at_end))

    async def _play(self, reader: ReadAhead[Any, Any]) -> None:
        """Deliver one recording's events when the clock reaches them (one task per recording)."""
        clock = self.clock
        loop = asyncio.get_running_loop()
        slice_end = loop.time() + DELIVERY_SLICE
        while True:
            reader.ready.clear()
            item = reader.peek()
            if item is None or item.payload is None:  # nothing read yet, or the end of this bag
                await reader.ready.wait()
                slice_end = loop.time() + DELIVERY_SLICE
                continue
            delay = clock.wall_delay(item.position)
            if delay is None or delay > 0:
                await _wait(reader.ready, delay)
                slice_end = loop.time() + DELIVERY_SLICE
                continue
            # No await between peek and here: a seek (also on the loop) cannot slip in between.
            reader.pop()
            self._deliver(item.payload)
            if loop.time() >= slice_end:
                await asyncio.sleep(0)
                slice_end = loop.time() + DELIVERY_SLICE

    def _deliver(self, payload: Payload) -> None:
        if isinstance(payload, _Image):
            self._cameras.offer(payload)
            return
        if isinstance(payload, _Cloud):
            if self._clouds is not None:  # at its rate, decoded on the intake's thread
                self._clouds.offer(payload.robot, payload.name, payload.message)
            return
        if isinstance(payload, PoseEvent):
            self._last["pose", payload.robot] = payload
        elif isinstance(payload, AvatarEvent):
            self._last["avatar", payload.client] = payload
        elif isinstance(payload, ScanEvent) and not self._scan_cap.allow(
            payload.robot, asyncio.get_running_loop().time()
        ):
            return  # at most MAX_SCAN_RATE scans a second of wall time, whatever the replay rate
        self._sink(payload)

    async def _tick(self) -> None:
        """Report the position once a second; at the end, loop or stay paused; keep paused robots online."""
        loop = asyncio.get_running_loop()
        clock = self.clock
        next_report = loop.time()
        while True:
            self._ticker_wake.clear()
            if not clock.paused and clock.position() >= clock.duration:
                if self._loop_at_end and clock.duration > 1e-3:
                    logger.info("end of the recordings: starting over")
                    self._restart(0.0)
                else:
                    logger.info("end of the recordings: paused at %.1f s", clock.duration)
                    clock.pause()
                self._changed()
                continue
            now = loop.time()
            if now >= next_report:
                next_report = now + PLAYBACK_REPORT_PERIOD
                self._emit_playback()
                if clock.paused:
                    # A paused recording still shows its robots where they are, so they stay online, and its
                    # operators where they were, for a page that connects meanwhile.
                    for last in self._last.values():
                        self._sink(last)
            timeout = next_report - now
            if not clock.paused:
                timeout = min(timeout, (clock.duration - clock.position()) / clock.rate)
            await _wait(self._ticker_wake, timeout)
