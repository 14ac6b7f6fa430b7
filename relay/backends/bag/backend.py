"""The bag backend on the event loop: playback of the bound recordings, cameras, playback commands."""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import math
from collections.abc import Callable, Sequence

from ...config import FleetConfig
from ...errors import BackendUnavailable, CommandRejected
from ...events import (
    CameraError,
    EventSink,
    FrameEvent,
    PlaybackEvent,
    PoseEvent,
    RobotModelEvent,
    ScanEvent,
)
from ...frame_encoder import LatestFrameEncoder
from ...options import BagOptions
from ...protocol import MAX_PLAYBACK_RATE, MAX_SCAN_RATE, MIN_PLAYBACK_RATE, ErrorCode
from ...rosmsg import (
    image_to_frame,
)
from ...scan import RateCap
from ..base import Backend
from .binding import BagContents, BagPlan, BagSpec, _lookup, bind_bags, parse_bag_specs
from .clock import PlaybackClock
from .decoding import Payload, _first_string, _Image
from .reader import _BagReader

logger = logging.getLogger(__name__)

#: How often the playback position is reported when nothing changes (s).
PLAYBACK_REPORT_PERIOD = 1.0
#: A snapshot waits this long for a camera's first image (s).
SNAPSHOT_TIMEOUT = 2.0
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


class BagBackend(Backend):
    """Replays recordings as the robots of robots.yaml. Everything here runs on the event loop."""

    name = "bag"

    def __init__(self, config: FleetConfig, sink: EventSink, options: BagOptions) -> None:
        """Check the arguments (cheap: a stat per path); opening the bags happens in :meth:`start`."""
        super().__init__(config, sink)
        if not (math.isfinite(options.rate) and MIN_PLAYBACK_RATE <= options.rate <= MAX_PLAYBACK_RATE):
            raise BackendUnavailable(
                f"--rate {options.rate:g}: expected a speed factor from {MIN_PLAYBACK_RATE:g} to {MAX_PLAYBACK_RATE:g}"
            )
        if not (math.isfinite(options.start) and options.start >= 0):
            raise BackendUnavailable(f"--start {options.start:g}: expected seconds from the recordings' start, >= 0")
        self.options = options
        self._specs = parse_bag_specs(options.bags, config)
        self._readers: list[_BagReader] = []
        self._plans: list[BagPlan] = []
        self._bound: dict[str, BagSpec] = {}
        self._clock: PlaybackClock | None = None
        self._tasks: list[asyncio.Task[None]] = []
        self._ticker_wake = asyncio.Event()
        self._last_pose: dict[str, PoseEvent] = {}
        self._scan_cap = RateCap(MAX_SCAN_RATE)
        self._cameras: dict[tuple[str, str], LatestFrameEncoder[_Image]] = {}
        #: Streamed cameras whose viewers all take H.264: their raw images are not JPEG-encoded (set_jpeg).
        self._no_jpeg: set[tuple[str, str]] = set()
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=2, thread_name_prefix="bag-jpeg")

    # -- lifecycle --------------------------------------------------------------------------------

    async def _send_models(self, plans: Sequence[BagPlan], contents: Sequence[BagContents]) -> None:
        """Robots whose model comes from robot_description get the URDF recorded in their bag, whatever the
        start position (it is published once, at the beginning)."""
        for spec, plan, content in zip(self._specs, plans, contents, strict=True):
            for topics in plan.robots:
                source = topics.robot.model_source
                if source is None:
                    continue
                topic = _lookup(source.topic, topics.robot, content.topics, strip=True)
                if topic is None or content.topics[topic] != "std_msgs/msg/String":
                    logger.warning("%s: no robot_description (%s) for %s", spec.shown, source.topic, topics.robot.name)
                    continue
                urdf = await asyncio.to_thread(_first_string, spec.path, topic)
                if urdf:
                    self.sink(RobotModelEvent(topics.robot.name, urdf))

    async def start(self) -> None:
        """Open every bag (reader threads), bind them to robots and start playing.

        Raises BackendUnavailable naming the file when a bag is missing, corrupt or truncated, or does not
        fit robots.yaml; nothing keeps running then.
        """
        loop = asyncio.get_running_loop()
        readers = [_BagReader(spec, loop) for spec in self._specs]
        for reader in readers:
            reader.start_thread()
        try:
            contents = [await asyncio.wrap_future(reader.opened) for reader in readers]
            plans = bind_bags(self.config, self._specs, contents)
        except BaseException:
            await self._close(readers)
            raise
        self._readers, self._plans = readers, plans
        duration = max(c.duration for c in contents)
        start = min(self.options.start, duration)
        if start < self.options.start:
            logger.warning(
                "--start %.1f is past the end of the recordings (%.1f s): starting at the end",
                self.options.start,
                duration,
            )
        self._clock = PlaybackClock(loop.time, duration, self.options.rate, start)
        for spec, plan in zip(self._specs, plans, strict=True):
            for topics in plan.robots:
                self._bound[topics.robot.name] = spec
                for camera, _ in topics.cameras:
                    key = (topics.robot.name, camera.name)
                    self._cameras[key] = self._frame_encoder(*key)
                logger.info("%s plays %s: %s", topics.robot.name, spec.shown, topics.describe())
            if plan.map_topic is not None:
                logger.info("the map comes from %s of %s", plan.map_topic, spec.shown)
        offline = [r for r in self.config.names if r not in self._bound]
        if offline:
            logger.info("not in any recording, offline: %s", ", ".join(offline))
        await self._send_models(plans, contents)
        for reader, plan in zip(readers, plans, strict=True):
            reader.play(plan, start)
            self._tasks.append(loop.create_task(self._play(reader), name=f"bag-play-{reader.spec.path.name}"))
        self._tasks.append(loop.create_task(self._tick(), name="bag-playback"))
        self._emit_playback()  # before any client connects: the first hello already says where playback is
        logger.info(
            "replaying %d bag(s): %.1f s from %.1f s at rate %g%s",
            len(readers),
            duration,
            start,
            self.options.rate,
            ", looping" if self.options.loop else "",
        )

    async def stop(self) -> None:
        tasks, self._tasks = self._tasks, []
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        readers, self._readers = self._readers, []
        await self._close(readers)
        self._pool.shutdown(wait=False, cancel_futures=True)

    @staticmethod
    async def _close(readers: Sequence[_BagReader]) -> None:
        for reader in readers:
            reader.close()

        def join() -> None:
            for reader in readers:
                reader.join(2.0)

        await asyncio.to_thread(join)

    # -- commands: a recording cannot be commanded ------------------------------------------------

    def command_refusal(self, robot: str) -> str | None:
        spec = self._bound.get(robot)
        if spec is not None:
            return f"{robot} is a recording (bag {spec.shown}); it cannot be commanded"
        return f"{robot} is not in any of the replayed recordings; with --backend bag no robot can be commanded"

    async def send_velocity(self, robot: str, linear: float, angular: float, *, stamp: float | None = None) -> None:
        """Nothing to drive: only stop paths (deadman, estop, shutdown) get here, and a recording is stopped."""

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        """Never reached for goals (command_refusal refuses them all); a no-op."""

    async def cancel(self, robot: str) -> None:
        """Only stop paths get here; a recording has no goal to cancel."""

    # -- playback ---------------------------------------------------------------------------------

    def _require_clock(self) -> PlaybackClock:
        if self._clock is None:
            raise CommandRejected(ErrorCode.INTERNAL, "the recordings are not open yet")
        return self._clock

    async def playback(self, action: str, value: float | None) -> None:
        """Pause, resume, seek (``value`` s from the start, clamped) or set the rate (``value``)."""
        clock = self._require_clock()
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

    def _restart(self, position: float) -> None:
        clock = self._require_clock()
        clock.seek(position)
        self._scan_cap.clear()
        self._last_pose.clear()  # the paused re-report must not resend a pose from before the seek
        for frames in self._cameras.values():
            frames.forget_latest()  # an image from another time must not answer a snapshot
        for reader in self._readers:
            reader.restart(position)

    def _changed(self) -> None:
        """The clock changed: re-plan every delivery, and report the new state now."""
        for reader in self._readers:
            reader.ready.set()
        self._emit_playback()
        self._ticker_wake.set()

    def _emit_playback(self) -> None:
        clock = self._clock
        if clock is not None:
            self.sink(PlaybackEvent(clock.position(), clock.duration, clock.rate, clock.paused, self.options.loop))

    def health(self) -> dict[str, object]:
        clock = self._clock
        if clock is None:
            return {}
        return {
            "playback": {
                "position": round(clock.position(), 3),
                "duration": round(clock.duration, 3),
                "rate": clock.rate,
                "paused": clock.paused,
                "loop": self.options.loop,
            },
            # Names, not paths: /healthz answers anyone, and a path says where the relay keeps its files.
            "bags": [
                {"name": spec.path.name, "robots": [t.robot.name for t in plan.robots]}
                for spec, plan in zip(self._specs, self._plans, strict=True)
            ],
        }

    async def _play(self, reader: _BagReader) -> None:
        """Deliver one bag's events when the clock reaches them (one task per bag)."""
        clock = self._require_clock()
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
            self._on_image(payload)
            return
        if isinstance(payload, PoseEvent):
            self._last_pose[payload.robot] = payload
        elif isinstance(payload, ScanEvent) and not self._scan_cap.allow(
            payload.robot, asyncio.get_running_loop().time()
        ):
            return  # at most MAX_SCAN_RATE scans a second of wall time, whatever the replay rate
        self.sink(payload)

    async def _tick(self) -> None:
        """Report the position once a second; at the end, loop or stay paused; keep paused robots online."""
        loop = asyncio.get_running_loop()
        clock = self._require_clock()
        next_report = loop.time()
        while True:
            self._ticker_wake.clear()
            if not clock.paused and clock.position() >= clock.duration:
                if self.options.loop and clock.duration > 1e-3:
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
                    # A paused recording still shows its robots where they are, so they stay online.
                    for pose in self._last_pose.values():
                        self.sink(pose)
            timeout = next_report - now
            if not clock.paused:
                timeout = min(timeout, (clock.duration - clock.position()) / clock.rate)
            await _wait(self._ticker_wake, timeout)

    # -- cameras ----------------------------------------------------------------------------------

    def _on_image(self, image: _Image) -> None:
        frames = self._cameras.get((image.robot, image.camera))
        if frames is not None:
            frames.offer(image)

    def _frame_encoder(self, robot: str, camera: str) -> LatestFrameEncoder[_Image]:
        def convert(image: _Image) -> FrameEvent:
            # Worker thread: a snapshot waiting for this frame needs its JPEG whatever the stream's viewers take.
            frames = self._cameras[(robot, camera)]
            jpeg = (robot, camera) not in self._no_jpeg or frames.waiting
            return image_to_frame(image.robot, image.camera, image.stamp, image.message, image.compressed, jpeg=jpeg)

        def fail(message: str) -> None:
            self.sink(CameraError(robot, camera, message))

        loop = asyncio.get_running_loop()
        return LatestFrameEncoder(
            f"{robot} camera {camera}",
            convert,
            self._pool,
            loop.call_soon_threadsafe,
            self.sink,
            keep_latest=True,
            fail=fail,
        )

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        frames = self._cameras.get((robot, camera))
        if frames is not None:
            frames.fps = fps

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:
        if wanted:
            self._no_jpeg.discard((robot, camera))
        else:
            self._no_jpeg.add((robot, camera))

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        """The JPEG of the camera's image at the playback position (also while paused), or None."""
        frames = self._cameras.get((robot, camera))
        clock = self._clock
        if frames is None or clock is None:
            return None
        if frames.latest is None and clock.paused:
            return None  # no image at this position, and none is coming
        return await frames.snapshot(SNAPSHOT_TIMEOUT, max_age=None, on_wait=frames.encode_latest)
