"""The server under test, in a process of its own (so its CPU time is its own, and the clients' is not).

    python -m bench.relay_proc --server xr|naive|foxglove [--backend synthetic|ros|sim|zenoh] [--robots N] ...

Prints ``{"port": N, "pid": P}`` once it listens, then answers ``stats`` on stdin with one JSON line
(``{"reply": "stats", "events": ..., "frames": ...}``) and exits on ``quit``, end of input or SIGTERM.

Servers:

- ``xr``: the real relay (``relay.net.server.create_app``) with one of the backends below.
- ``naive``: the relay as the thesis prototype worked, written here for the baseline: every message is put
  in every client's unbounded queue and JSON-encoded per client (stdlib ``json``), nothing is coalesced.
- ``foxglove``: the Foxglove SDK's WebSocket server (Rust), one JSON channel per robot.

Backends of ``xr``:

- ``synthetic``: R robots driving circles, each pose published at ``--rate`` Hz, the robots' phases spread
  over the period as independent robots' are. Events come from a producer *thread* and cross to the loop
  with ``loop.call_soon_threadsafe``, exactly as the ros backend's do, stamped with ``time.monotonic()``
  just before the crossing: the clients' receive time minus that stamp is the latency the relay adds
  (thread hop, encoding, queueing, sending, loopback). The naive relay and Foxglove get the same producer.
- ``ros``: the real ros backend against a robots.yaml (``--config``); events are counted on their way in.
- ``zenoh``: the real zenoh backend, connected to ``--zenoh-connect`` (bench/zenoh_pub.py's router); counted
  the same way.
- ``sim``: the real sim backend against a robots.yaml, optionally with a camera served from a JPEG
  (``--camera-jpeg``) instead of the ray-cast one, so that the browser benchmark measures the client.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import json
import logging
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from aiohttp import web

from relay.backends.base import Backend
from relay.cli.options import Options
from relay.config import Cloud, FleetConfig, load_config, parse_config
from relay.fleet.events import Event, EventSink, FrameEvent, PoseEvent
from relay.fleet.geometry import yaw_to_quaternion
from relay.station.messages import encode, pose_message

from .map_feed import MapFeed

logger = logging.getLogger("bench.relay_proc")


def emit_line(record: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(record) + "\n")
    sys.stdout.flush()


def synthetic_fleet_yaml(robots: int, camera: tuple[int, int, float] | None) -> str:
    """robots.yaml text for ``robots`` robots r001..; the first has a camera when ``camera`` is given."""
    lines = ["robots:"]
    for i in range(robots):
        lines.append(f"  - name: r{i + 1:03d}")
        lines.append("    pose: odom")
        lines.append("    limits: {linear: 0.5, angular: 1.0}")
        if i == 0 and camera is not None:
            width, height, rate = camera
            lines.append(
                "    cameras: [{name: front, lens: {model: equidistant, fov: 180}, "
                f"width: {width}, height: {height}, rate: {rate:g}}}]"
            )
    return "\n".join(lines) + "\n"


class Producer(threading.Thread):
    """Poses of ``count`` robots at ``rate`` Hz each, spread over the period, until stopped."""

    #: Wake-ups per period at most: 300 robots at 30 Hz is 9000 poses/s in 50 groups of 6.
    MAX_GROUPS = 50

    def __init__(self, count: int, rate: float, emit: Callable[[int, float, float, float, float], None]) -> None:
        super().__init__(name="pose-producer", daemon=True)
        self.count = count
        self.rate = rate
        self.emit = emit
        self.emitted = 0
        self._stop_event = threading.Event()
        #: Set by the ``start`` command: the load begins once every client is connected, so that
        #: connecting is not measured under a load only some of them see.
        self.go = threading.Event()
        groups = max(1, min(count, self.MAX_GROUPS))
        self._groups = [list(range(k, count, groups)) for k in range(groups)]

    def stop(self) -> None:
        self._stop_event.set()

    def run(self) -> None:
        while not self.go.wait(0.1):
            if self._stop_event.is_set():
                return
        period = 1.0 / self.rate
        slot = period / len(self._groups)
        t0 = time.monotonic()
        cycle = 0
        while not self._stop_event.is_set():
            base = t0 + cycle * period
            for k, group in enumerate(self._groups):
                delay = base + k * slot - time.monotonic()
                if delay > 0 and self._stop_event.wait(delay):
                    return
                for index in group:
                    t = time.monotonic()
                    # Robot i drives a 1 m circle at its own phase: every pose differs, as live ones do.
                    angle = 0.5 * t + index
                    x = 2.0 + (index % 20) * 0.8 + math.cos(angle)
                    y = 2.0 + (index // 20) * 0.8 + math.sin(angle)
                    self.emit(index, t, x, y, angle + math.pi / 2)
                    self.emitted += 1
            cycle += 1
            if time.monotonic() - (t0 + cycle * period) > 1.0:
                # Starved for a second (the machine is overloaded): do not burst to catch up.
                t0 = time.monotonic() - cycle * period


class FrameProducer(threading.Thread):
    """JPEG frames of one camera at ``fps``, from a worker thread as the ros backend's encoder posts them."""

    def __init__(self, fps: float, emit: Callable[[float], None]) -> None:
        super().__init__(name="frame-producer", daemon=True)
        self.fps = fps
        self.emit = emit
        self.emitted = 0
        self._stop_event = threading.Event()

    def stop(self) -> None:
        self._stop_event.set()

    def run(self) -> None:
        period = 1.0 / self.fps
        due = time.monotonic()
        while not self._stop_event.is_set():
            self.emit(time.monotonic())
            self.emitted += 1
            due = max(due + period, time.monotonic() - period)
            if self._stop_event.wait(max(0.0, due - time.monotonic())):
                return


def pose_event(name: str, stamp: float, x: float, y: float, yaw: float) -> PoseEvent:
    qx, qy, qz, qw = yaw_to_quaternion(yaw)
    return PoseEvent(name, stamp, "map", x, y, 0.0, qx, qy, qz, qw)


class SyntheticBackend(Backend):
    """The synthetic robots as a relay backend (commands are accepted and ignored)."""

    name = "synthetic"

    def __init__(
        self, config: FleetConfig, sink: EventSink, rate: float, jpeg: bytes | None, map_feed: float = 0.0
    ) -> None:
        super().__init__(config, sink)
        self._names = [r.name for r in config.robots]
        self._rate = rate
        self._jpeg = jpeg
        self._map_feed = map_feed  # Hz of the first robot's lidar (bench/map_feed.py), 0: none
        self.feed: MapFeed | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self.producer: Producer | None = None
        self.cameras: dict[tuple[str, str], FrameProducer] = {}
        self.frames = 0

    def _post(self, event: Event) -> None:
        loop = self._loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop closed under us at shutdown
                loop.call_soon_threadsafe(self.sink, event)

    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        names = self._names
        self.producer = Producer(
            len(names), self._rate, lambda i, t, x, y, yaw: self._post(pose_event(names[i], t, x, y, yaw))
        )
        self.producer.start()
        if self._map_feed > 0:
            self.feed = MapFeed(names[0], self._map_feed, self._post)
            self.feed.start()

    async def stop(self) -> None:
        if self.feed is not None:
            self.feed.stop()
        if self.producer is not None:
            self.producer.stop()
            await asyncio.to_thread(self.producer.join, 2.0)
        for camera in self.cameras.values():
            camera.stop()
        self.cameras.clear()

    async def send_velocity(self, robot: str, linear: float, angular: float) -> None:
        return None

    async def send_goal(
        self, robot: str, x: float, y: float, yaw: float | None, *, current: Callable[[], bool] = lambda: True
    ) -> None:
        return None

    async def cancel(self, robot: str) -> None:
        return None

    def _frame(self, robot: str, camera: str, stamp: float) -> FrameEvent:
        assert self._jpeg is not None
        spec = self.config.robot(robot)
        assert spec is not None
        cam = spec.camera(camera)
        assert cam is not None
        return FrameEvent(robot, camera, stamp, cam.width, cam.height, self._jpeg)

    async def snapshot(self, robot: str, camera: str) -> FrameEvent | None:
        return self._frame(robot, camera, time.monotonic()) if self._jpeg is not None else None

    def set_stream(self, robot: str, camera: str, fps: float) -> None:
        current = self.cameras.pop((robot, camera), None)
        if current is not None:
            current.stop()
        if fps > 0 and self._jpeg is not None:

            def emit(stamp: float) -> None:
                self.frames += 1
                self._post(self._frame(robot, camera, stamp))

            producer = FrameProducer(fps, emit)
            self.cameras[(robot, camera)] = producer
            producer.start()


def jpeg_of(path: str, width: int, height: int) -> bytes:
    import cv2

    image = cv2.imread(path)
    if image is None:
        raise SystemExit(f"cannot read {path}")
    ok, data = cv2.imencode(".jpg", cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA))
    assert ok
    return bytes(data.tobytes())


class Counter:
    """Counts the backend's events on their way into the relay (the ros backend's ingest rate)."""

    def __init__(self, sink: EventSink) -> None:
        self.sink = sink
        self.poses = 0
        self.frames = 0
        self.other = 0

    def __call__(self, event: Event) -> None:
        if isinstance(event, PoseEvent):
            self.poses += 1
        elif isinstance(event, FrameEvent):
            self.frames += 1
        else:
            self.other += 1
        self.sink(event)


def relay_options(
    backend: str,
    token: str | None,
    zenoh_connect: str | None = None,
    record_session: str | None = None,
    database: str | None = None,
) -> Options:
    names = {f.name for f in dataclasses.fields(Options)}
    kwargs: dict[str, Any] = {"backend": backend, "audit_log": None, "database": database}
    if record_session and "record_session" in names:
        kwargs["record_session"] = record_session
    if token and "token" in names:
        kwargs["token"] = token
    if zenoh_connect:
        from relay.cli.options import ZenohOptions

        kwargs["zenoh"] = ZenohOptions(connect=(zenoh_connect,))
    return Options(**kwargs)


async def serve_xr(args: argparse.Namespace, config: FleetConfig, jpeg: bytes | None) -> None:
    from relay.backends import create_backend
    from relay.net.server import RELAY_KEY, create_app, open_runner

    synthetic: SyntheticBackend | None = None
    counter: Counter | None = None

    def counting_backend(cfg: FleetConfig, sink: EventSink, options: Options) -> Backend:
        """The backend, built around a counting sink: parts of a backend keep the sink they were built with (the
        ros backend's camera encoders), so it is wrapped before, never swapped after. The benchmark's own synthetic
        backend is built here too (the relay does not build it by name). Until 2026-11-23 it was swapped in as
        relay.station.core.create_backend, which Relay's default argument had already bound: the xr cells measured the
        sim backend, and frames of the ros backend's cameras went past the swapped-in counter."""
        nonlocal synthetic, counter
        counter = Counter(sink)
        if args.backend == "synthetic":
            synthetic = SyntheticBackend(cfg, counter, args.rate, jpeg, args.map_feed)
            return synthetic
        return create_backend(cfg, counter, options)

    options = relay_options(
        "sim" if args.backend == "synthetic" else args.backend,
        args.token,
        args.zenoh_connect,
        args.record_session,
        args.database,
    )
    # The benchmarks' publishers stamp with time.monotonic() (bench/ros_pub.py, the synthetic backend): it is the
    # relay's clock of record here, so that the latency it exports and the page shows compare the same clocks.
    app = create_app(config, options, backend_factory=counting_backend, wall_clock=time.monotonic)
    the_relay = app[RELAY_KEY]
    backend = the_relay.backend
    assert counter is not None
    counted: Counter = counter
    if args.backend == "sim" and jpeg is not None:
        install_jpeg_camera(backend, config, jpeg)
    images = count_images(backend)
    runner = await open_runner(app)  # as `xr-relay` runs it: guarded connections
    try:
        site = web.TCPSite(runner, "127.0.0.1", 0)
        await site.start()
        port = runner.addresses[0][1]

        def stats() -> dict[str, Any]:
            if synthetic is not None:
                producer = synthetic.producer
                return {"events": producer.emitted if producer else 0, "frames": synthetic.frames}
            # The ros backend also says how many messages it took from DDS (poses of one robot that arrive while
            # the loop is busy are coalesced before the sink: "events" counts what reached the relay's core).
            ingest = getattr(backend, "ingest_stats", dict)()
            return {
                "events": counted.poses,
                "frames": counted.frames,
                "other": counted.other,
                "images": images[0],
                **ingest,
            }

        def start() -> None:
            if synthetic is not None and synthetic.producer is not None:
                synthetic.producer.go.set()

        emit_line({"port": port, "pid": os.getpid()})
        await control_loop(stats, start)
    finally:
        await runner.cleanup()


def count_images(backend: Backend) -> list[int]:
    """Count the images DDS hands the ros backend (before its own rate limit and encoder), so the camera
    benchmark can tell frames lost in DDS from frames the backend skipped. The backend's cameras
    (relay.backends.cameras) subscribe on demand through the function they were given: wrapping it here, before
    any stream starts, counts every image each subscription's callback gets. Another backend reports 0."""
    seen = [0]
    cameras = getattr(backend, "_cameras", None)
    subscribe = getattr(cameras, "_subscribe", None)
    if cameras is None or subscribe is None:
        return seen

    def counting_subscribe(spec: Any, callback: Callable[[Any], None]) -> Any:
        def counted(message: Any) -> None:
            seen[0] += 1  # the executor thread is the only writer
            callback(message)

        return subscribe(spec, counted)

    setattr(cameras, "_subscribe", counting_subscribe)  # noqa: B010 - an instance attribute, wrapped on purpose
    return seen


def install_jpeg_camera(backend: Backend, config: FleetConfig, jpeg: bytes) -> None:
    """Serve every camera of the sim backend from one JPEG (the browser benchmark measures the client's
    decode and upload, not the ray caster's ~100 ms per frame)."""
    loop = asyncio.get_running_loop()
    streams: dict[tuple[str, str], FrameProducer] = {}

    def frame(robot: str, camera: str, stamp: float) -> FrameEvent:
        spec = config.robot(robot)
        assert spec is not None
        cam = spec.camera(camera)
        assert cam is not None
        return FrameEvent(robot, camera, stamp, cam.width, cam.height, jpeg)

    async def snapshot(robot: str, camera: str) -> FrameEvent | None:
        return frame(robot, camera, time.monotonic())

    def set_stream(robot: str, camera: str, fps: float) -> None:
        current = streams.pop((robot, camera), None)
        if current is not None:
            current.stop()
        if fps > 0:

            def emit(stamp: float) -> None:
                with contextlib.suppress(RuntimeError):
                    loop.call_soon_threadsafe(backend.sink, frame(robot, camera, stamp))

            producer = FrameProducer(fps, emit)
            streams[(robot, camera)] = producer
            producer.start()

    backend.snapshot = snapshot  # type: ignore[method-assign]
    backend.set_stream = set_stream  # type: ignore[method-assign]


class NaiveRelay:
    """The baseline: per-client JSON encoding, every message to every client, unbounded queues."""

    def __init__(self) -> None:
        self.queues: set[asyncio.Queue[dict[str, Any]]] = set()

    def publish(self, event: PoseEvent) -> None:
        message = dict(
            pose_message(
                event.robot,
                stamp=event.stamp,
                frame=event.frame,
                x=event.x,
                y=event.y,
                z=event.z,
                qx=event.qx,
                qy=event.qy,
                qz=event.qz,
                qw=event.qw,
            )
        )
        for queue in self.queues:
            queue.put_nowait(message)

    async def handler(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(compress=False)
        await ws.prepare(request)
        queue: asyncio.Queue[dict[str, Any]] = asyncio.Queue()
        await ws.send_str(json.dumps({"identifier": "hello", "protocol": 1}))
        self.queues.add(queue)

        async def writer() -> None:
            while True:
                message = await queue.get()
                await ws.send_str(json.dumps(message))  # encoded again for every client

        task = asyncio.get_running_loop().create_task(writer())
        try:
            async for _ in ws:
                pass
        finally:
            self.queues.discard(queue)
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, ConnectionError):
                await task
        return ws


async def serve_naive(args: argparse.Namespace, names: list[str]) -> None:
    naive = NaiveRelay()
    loop = asyncio.get_running_loop()

    def emit(i: int, t: float, x: float, y: float, yaw: float) -> None:
        with contextlib.suppress(RuntimeError):
            loop.call_soon_threadsafe(naive.publish, pose_event(names[i], t, x, y, yaw))

    app = web.Application()
    app.router.add_get("/ws", naive.handler)
    runner = web.AppRunner(app, shutdown_timeout=1.0, access_log=None)
    await runner.setup()
    producer = Producer(len(names), args.rate, emit)
    try:
        site = web.TCPSite(runner, "127.0.0.1", 0)
        await site.start()
        producer.start()
        emit_line({"port": runner.addresses[0][1], "pid": os.getpid()})
        await control_loop(lambda: {"events": producer.emitted, "frames": 0}, producer.go.set)
    finally:
        producer.stop()
        await runner.cleanup()


async def serve_foxglove(args: argparse.Namespace, names: list[str]) -> None:
    import foxglove

    foxglove.set_log_level(logging.WARNING)
    context = foxglove.Context()
    server = foxglove.start_server(name="bench", host="127.0.0.1", port=0, context=context)
    channels = [foxglove.Channel(f"/{n}/pose", message_encoding="json", context=context) for n in names]

    def emit(i: int, t: float, x: float, y: float, yaw: float) -> None:
        event = pose_event(names[i], t, x, y, yaw)
        message = pose_message(
            event.robot,
            stamp=event.stamp,
            frame=event.frame,
            x=event.x,
            y=event.y,
            z=event.z,
            qx=event.qx,
            qy=event.qy,
            qz=event.qz,
            qw=event.qw,
        )
        # Same bytes as xr-relay sends, logged from the producer thread: Foxglove's API is thread-safe and
        # its server runs on its own (Rust) threads, so there is no loop to hop to.
        channels[i].log(encode(message))

    producer = Producer(len(names), args.rate, emit)
    try:
        producer.start()
        emit_line({"port": server.port, "pid": os.getpid()})
        await control_loop(lambda: {"events": producer.emitted, "frames": 0}, producer.go.set)
    finally:
        producer.stop()
        producer.join(2.0)
        server.stop()


async def control_loop(stats: Callable[[], dict[str, Any]], start: Callable[[], None] = lambda: None) -> None:
    """Answer ``stats`` and ``start`` until ``quit``, end of input, or SIGTERM.

    stdin is read by a thread, not the loop: a server whose loop is swamped (the naive relay under
    overload) still answers, so the benchmark's windows stay bounded in time.
    """
    loop = asyncio.get_running_loop()
    done = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, done.set)

    def read() -> None:
        for raw in sys.stdin:
            command = raw.strip()
            if command == "quit":
                break
            if command == "stats":
                emit_line({"reply": "stats", "t": time.monotonic(), **stats()})
            elif command == "start":
                start()
                emit_line({"reply": "start", "t": time.monotonic()})
        with contextlib.suppress(RuntimeError):
            loop.call_soon_threadsafe(done.set)

    threading.Thread(target=read, name="control", daemon=True).start()
    await done.wait()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--server", choices=("xr", "naive", "foxglove"), default="xr")
    parser.add_argument("--backend", choices=("synthetic", "ros", "sim", "zenoh"), default="synthetic")
    parser.add_argument("--zenoh-connect", default=None, help="the zenoh backend's router (tcp/127.0.0.1:PORT)")
    parser.add_argument("--robots", type=int, default=3, help="synthetic robots")
    parser.add_argument("--rate", type=float, default=30.0, help="pose rate of each synthetic robot (Hz)")
    parser.add_argument("--config", help="robots.yaml for the ros and sim backends")
    parser.add_argument("--camera-jpeg", help="serve cameras from this photo (synthetic and sim backends)")
    parser.add_argument("--camera-size", type=int, nargs=2, default=(480, 480), metavar=("W", "H"))
    parser.add_argument("--camera-rate", type=float, default=30.0)
    parser.add_argument("--token", default=None)
    parser.add_argument("--record-session", default=None, help="record the session to this MCAP file (xr only)")
    parser.add_argument("--map-feed", type=float, default=0.0, help="a robot's lidar at this rate (Hz): a 3D map")
    parser.add_argument("--database", default=None, help="the inspection database (xr only; the 3D map's file beside)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="%(asctime)s %(name)s %(message)s")

    width, height = args.camera_size
    jpeg = jpeg_of(args.camera_jpeg, width, height) if args.camera_jpeg else None
    if args.config:
        config = load_config(Path(args.config))
        if jpeg is not None:
            # The photo stands in for every camera: give them its size and the rate asked for.
            robots = tuple(
                dataclasses.replace(
                    r,
                    cameras=tuple(
                        dataclasses.replace(c, width=width, height=height, rate=args.camera_rate) for c in r.cameras
                    ),
                )
                for r in config.robots
            )
            config = dataclasses.replace(config, robots=robots)
    else:
        camera = (width, height, args.camera_rate) if jpeg is not None else None
        config = parse_config(synthetic_fleet_yaml(args.robots, camera), "bench-fleet.yaml")
        if args.map_feed > 0:  # the live 3D map on, fed by bench/map_feed.py (the sim's depth cameras off)
            config = dataclasses.replace(config, cloud=Cloud(voxel=0.05, budget_blocks=20_000, sim_depth_rate=0.0))
    names = [r.name for r in config.robots]
    if args.server == "xr":
        asyncio.run(serve_xr(args, config, jpeg))
    elif args.server == "naive":
        asyncio.run(serve_naive(args, names))
    else:
        asyncio.run(serve_foxglove(args, names))


if __name__ == "__main__":
    main()
