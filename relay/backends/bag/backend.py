"""The bag backend on the event loop: the bound recordings opened and played, cameras, playback commands."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Sequence

from ...cli.options import BagOptions
from ...config import FleetConfig
from ...fleet.events import CloudEvent, EventSink, FrameEvent, RobotModelEvent
from ..cloud_intake import CloudIntake, cloud_intake
from .binding import BagContents, BagPlan, BagSpec, _lookup, bind_bags, parse_bag_specs
from .cameras import BagCameras
from .clock import PlaybackClock
from .decoding import _first_string
from .player import Player
from .reader import _BagReader
from .recorded import RecordedFleet

logger = logging.getLogger(__name__)


class BagBackend(RecordedFleet):
    """Replays recordings as the robots of robots.yaml. Everything here runs on the event loop."""

    name = "bag"

    def __init__(self, config: FleetConfig, sink: EventSink, options: BagOptions) -> None:
        """Check the arguments (cheap: a stat per path); opening the bags happens in :meth:`start`."""
        super().__init__(config, sink, rate=options.rate, start=options.start, what="the recordings")
        self.options = options
        self._specs = parse_bag_specs(options.bags, config)
        self._readers: list[_BagReader] = []
        self._plans: list[BagPlan] = []
        self._bound: dict[str, BagSpec] = {}
        self._cameras = BagCameras(sink)
        self._clouds: CloudIntake | None = None  # the robots' recorded clouds, with robots.yaml's cloud

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

        def emit(event: CloudEvent) -> None:  # the intake's thread to the loop
            if not loop.is_closed():
                with contextlib.suppress(RuntimeError):  # closed meanwhile (shutdown)
                    loop.call_soon_threadsafe(self.sink, event)

        self._clouds = cloud_intake(self.config, emit)
        readers = [_BagReader(spec, loop, self._clouds) for spec in self._specs]
        for reader in readers:
            reader.start_thread()
        try:
            contents = [await asyncio.wrap_future(reader.opened) for reader in readers]
            plans = bind_bags(self.config, self._specs, contents)
        except BaseException:
            await self._close(readers)
            if self._clouds is not None:
                self._clouds.stop()
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
        clock = PlaybackClock(loop.time, duration, self.options.rate, start)
        player = self._player = Player(
            clock, readers, self.sink, self._cameras, loop_at_end=self.options.loop, clouds=self._clouds
        )
        for spec, plan in zip(self._specs, plans, strict=True):
            for topics in plan.robots:
                self._bound[topics.robot.name] = spec
                for camera, _ in topics.cameras:
                    self._cameras.add(topics.robot.name, camera.name)
                logger.info("%s plays %s: %s", topics.robot.name, spec.shown, topics.describe())
            if plan.map_topic is not None:
                logger.info("the map comes from %s of %s", plan.map_topic, spec.shown)
        offline = [r for r in self.config.names if r not in self._bound]
        if offline:
            logger.info("not in any recording, offline: %s", ", ".join(offline))
        await self._send_models(plans, contents)
        for reader, plan in zip(readers, plans, strict=True):
            reader.play(plan, start)
        player.start()
        logger.info(
            "replaying %d bag(s): %.1f s from %.1f s at rate %g%s",
            len(readers),
            duration,
            start,
            self.options.rate,
            ", looping" if self.options.loop else "",
        )

    async def stop(self) -> None:
        if self._player is not None:
            await self._player.stop()
        readers, self._readers = self._readers, []
        await self._close(readers)
        self._cameras.close()
        if self._clouds is not None:
            await asyncio.to_thread(self._clouds.stop)

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

    def health(self) -> dict[str, object]:
        if self._player is None:
            return {}
        return {
            **(self._clouds.health() if self._clouds is not None else {}),
            "playback": self._player.health(),
            # Names, not paths: /healthz answers anyone, and a path says where the relay keeps its files.
            "bags": [
                {"name": spec.path.name, "robots": [t.robot.name for t in plan.robots]}
                for spec, plan in zip(self._specs, self._plans, strict=True)
            ],
        }

    # -- cameras (relay.backends.bag.cameras) -----------------------------------------------------

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        self._cameras.set_stream(robot, camera, fps)

    def set_jpeg(self, robot: str, camera: str, wanted: bool) -> None:
        self._cameras.set_jpeg(robot, camera, wanted)

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        """The JPEG of the camera's image at the playback position (also while paused), or None."""
        if self._player is None:
            return None
        return await self._cameras.snapshot(robot, camera, paused=self._player.clock.paused)
