"""How the ros backend takes messages in: raw bytes, decoded only as far as the relay needs, handed to the loop
in batches. rclpy is not imported here (the backend passes its executors module in), so this is tested alone.

**Raw.** Every high-rate topic is subscribed with ``raw=True`` (the serialized CDR bytes, no rclpy message
built). Poses (Odometry, PoseStamped, PoseWithCovarianceStamped) are read by hand (``relay/cdr.py``: 4.4 us an
Odometry); TF, laser scans and images are decoded by ``rosbags`` (its typestore knows every standard type,
tf2_msgs included, and its objects have rclpy's attribute names, so ``relay.rosmsg``/``relay.scan`` read them
unchanged; an image's pixels stay a view of the received bytes). Per message, 2 cores, 2026-11-23:

    nav_msgs/Odometry            rclpy 70 us    rosbags 24 us    relay/cdr.py 4.4 us
    geometry_msgs/PoseStamped    rclpy 31 us    rosbags 10 us    relay/cdr.py ~4 us
    sensor_msgs/LaserScan (360)  rclpy 14 us    rosbags 7.6 us
    sensor_msgs/Image 640x480    rclpy 242 us   rosbags 79 us (the pixels not copied)

**Batches.** ``loop.call_soon_threadsafe`` per message costs a wake-up of the loop (a write to its self-pipe and a
pass through the selector) for each: at thousands of poses a second that was most of the relay's ingest.
:class:`Inbox` takes events from the executor thread and wakes the loop once for everything that arrived until the
loop gets to it, and at most once every :data:`BATCH_INTERVAL` (an idle relay still delivers a lone message at
once; a busy one every 2 ms: without the floor, a loop quicker than the messages woke for each of them, 4000
wake-ups a second for 100 robots at 30 Hz + 10 Hz scans). While it waits, a robot's newer pose replaces its older
one (the hub would send only the newest anyway: a pose is state); every other event is kept in order, up to
:data:`INBOX_LIMIT`, past which the oldest are dropped and counted (a loop stalled that long has bigger problems,
and memory must stay bounded).

**The executor.** rclpy's EventsExecutor dispatches from C++ and reaches 3.5x the SingleThreadedExecutor's
rate on raw Odometry (bench/bench_ros_ingest.py: 8.1k vs 2.35k a second). In this rclpy (9.1.2, PyPI wheels)
its ``spin()`` dispatches nothing from a thread other than the main one and its ``shutdown()`` then blocks for
ever; ``spin_until_future_complete`` works from a thread, subscriptions made and destroyed while it spins work
(bench/ros_sub.py checks both every run; tests/test_ros_ingest.py creates and destroys subscriptions while
spinning and stops it), so :class:`Spinner` spins it that way, until a future it owns is done.
``ros.executor: single`` in robots.yaml keeps the SingleThreadedExecutor.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from importlib import import_module
from typing import Any

from ..cdr import stamped_pose
from ..events import Event, PoseEvent

logger = logging.getLogger(__name__)

#: Events other than poses that may wait for the loop; past it the oldest go (counted in ``dropped``).
INBOX_LIMIT = 10_000
#: Seconds between two deliveries at least (what a pose may wait for others to join its batch).
BATCH_INTERVAL = 0.002


class LoopCrossing:
    """The thread boundary of a backend fed from another thread (rclpy's executor, Zenoh's callbacks, a worker):
    the backend sets ``_inbox`` and ``_loop`` when it starts."""

    _inbox: Inbox | None
    _loop: asyncio.AbstractEventLoop | None

    def _post(self, event: Event) -> None:
        """THE crossing from another thread to the loop; ``event`` is immutable."""
        if self._inbox is not None:
            self._inbox.put(event)

    def _hop(self, call: Callable[[], None]) -> None:
        """The same crossing for a call: a camera encoder's finished frame, another relay's estop or lease."""
        loop = self._loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop closed under a late call (shutdown)
                loop.call_soon_threadsafe(call)


class Inbox:
    """Events from the executor (or a worker) thread to the loop, one wake-up per batch.

    ``put`` runs on any thread; ``deliver`` gets each batch on the loop, poses last (newest of each robot).
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, deliver: Callable[[Event], None]) -> None:
        self._loop = loop
        self._deliver = deliver
        self._lock = threading.Lock()
        self._poses: dict[str, PoseEvent] = {}
        self._other: deque[Event] = deque()
        self._scheduled = False
        self._last_drain = -1.0
        #: Messages handed in, poses replaced while waiting, other events dropped over the limit.
        self.received = 0
        self.coalesced = 0
        self.dropped = 0

    def put(self, event: Event) -> None:
        with self._lock:
            self.received += 1
            if isinstance(event, PoseEvent):
                if self._poses.pop(event.robot, None) is not None:
                    self.coalesced += 1
                self._poses[event.robot] = event
            else:
                if len(self._other) >= INBOX_LIMIT:
                    self._other.popleft()
                    self.dropped += 1
                self._other.append(event)
            if self._scheduled:
                return
            self._scheduled = True
        if self._loop.is_closed():
            return
        # The loop may close between the check and the call (shutdown): then the event has nowhere to go.
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self._arm)

    def _arm(self) -> None:
        """On the loop: deliver now, or once BATCH_INTERVAL has passed since the last delivery."""
        delay = self._last_drain + BATCH_INTERVAL - self._loop.time()
        if delay > 0:
            self._loop.call_later(delay, self._drain)
        else:
            self._drain()

    def _drain(self) -> None:
        self._last_drain = self._loop.time()
        with self._lock:
            other, self._other = self._other, deque()
            poses, self._poses = self._poses, {}
            self._scheduled = False
        for event in other:
            self._deliver(event)
        for pose in poses.values():
            self._deliver(pose)

    def stats(self) -> dict[str, int]:
        with self._lock:
            return {"received": self.received, "coalesced": self.coalesced, "dropped": self.dropped}


def pose_reader(
    robot: str, *, child_frame: bool, put: Callable[[Event], None], warn: Callable[..., None] = logger.warning
) -> Callable[[bytes], None]:
    """The raw callback of one robot's Odometry (``child_frame``) or PoseStamped/PoseWithCovarianceStamped topic;
    ``warn`` takes the line about bytes that are not one (the zenoh backend's is rate-limited)."""

    def on_bytes(data: bytes) -> None:
        try:
            # A publisher that leaves the stamp or the frame unset gets the receive time and the map frame.
            pose = stamped_pose(data, robot, child_frame=child_frame, received=time.time())
        except (ValueError, struct.error, UnicodeDecodeError) as exc:
            warn("%s: undecodable pose message (%d bytes): %s", robot, len(data), exc)
            return
        put(pose)

    return on_bytes


class RawDecoder:
    """rosbags' CDR decoder for the raw topics the relay reads whole (TF, LaserScan, Image, CompressedImage, and
    Nav2's action: relay/nav2_types.py)."""

    def __init__(self) -> None:
        from ..nav2_types import typestore

        self._store = typestore()

    def __call__(self, data: bytes | memoryview, type_name: str) -> Any:
        """The message, with rclpy's attribute names; ValueError (naming the type) when the bytes are not one."""
        try:
            return self._store.deserialize_cdr(data, type_name)
        except Exception as exc:  # rosbags raises struct, index, unicode and its own errors on corrupt bytes
            raise ValueError(f"undecodable {type_name} ({len(data)} bytes): {exc}") from None


class Spinner:
    """One executor on one thread, stopped from any other: EventsExecutor (default) or SingleThreadedExecutor."""

    def __init__(self, executors: Any, context: Any, kind: str, on_failure: Callable[[str], None]) -> None:
        self.kind = kind
        self._context = context
        self._on_failure = on_failure
        # rclpy's Future: the EventsExecutor waits on its done callback (with concurrent.futures' Future it
        # dispatched some callbacks and missed most: 426 of 1000 Odometry a second, bench/bench_ros_ingest.py).
        self._stop: Any = import_module("rclpy.task").Future()
        self.executor = self._create(executors, context, kind)
        self._thread: threading.Thread | None = None

    @staticmethod
    def _create(executors: Any, context: Any, kind: str) -> Any:
        if kind == "events":
            try:
                events = import_module("rclpy.experimental.events_executor")
                return events.EventsExecutor(context=context)
            except (ImportError, AttributeError) as exc:  # an rclpy before Jazzy has none
                logger.warning("no EventsExecutor in this rclpy (%s): using the SingleThreadedExecutor", exc)
        return executors.SingleThreadedExecutor(context=context)

    def start(self, node: Any) -> None:
        self.executor.add_node(node)
        self._thread = threading.Thread(target=self._spin, name="ros-executor", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            if self.kind == "events":
                while not self._stop.done() and self._context.ok():
                    self.executor.spin_until_future_complete(self._stop, timeout_sec=1.0)
            else:
                self.executor.spin()
        except Exception as exc:  # the context was shut down under it, or rclpy failed
            if not self._stop.done():
                logger.exception("ROS executor stopped: %s", exc)
                self._on_failure(f"the ROS executor stopped: {exc}")
            return
        if not self._stop.done():
            # spin returned although nobody stopped us: the executor was shut down under the relay.
            self._on_failure("the ROS executor stopped")

    def stop(self, timeout: float = 2.0) -> None:
        """Blocking (a worker thread): end the spin, then shut the executor down. Never waits more than
        ``timeout`` for the thread; the EventsExecutor is shut down only once its thread has left it."""
        if not self._stop.done():
            self._stop.set_result(None)
        thread = self._thread
        if self.kind == "events":
            with contextlib.suppress(Exception):
                self.executor.wake()
            if thread is not None:
                thread.join(timeout)
            if thread is not None and thread.is_alive():
                logger.error("the ROS executor thread did not stop within %.1f s; left to the process's exit", timeout)
                return
            self.executor.shutdown(timeout_sec=1.0)
        else:
            self.executor.shutdown(timeout_sec=1.0)
            if thread is not None:
                thread.join(timeout)
