"""How the live backends (``ros``, ``zenoh``) take messages in: raw bytes, decoded only as far as the relay needs,
handed to the loop in batches. Neither rclpy nor zenoh is imported here, so this is tested alone.

**Raw.** Every high-rate topic arrives as the serialized CDR bytes (rclpy's ``raw=True``: no rclpy message built;
Zenoh's samples are bytes anyway). Poses (Odometry, PoseStamped, PoseWithCovarianceStamped) are read by hand
(``relay/ros/cdr.py``: 4.4 us an Odometry); TF, laser scans and images are decoded by ``rosbags`` (its typestore knows
every standard type, tf2_msgs included, and its objects have rclpy's attribute names, so ``relay.ros.rosmsg``/
``relay.fleet.scan`` read them unchanged; an image's pixels stay a view of the received bytes). Per message, 2 cores,
2026-11-23:

    nav_msgs/Odometry            rclpy 70 us    rosbags 24 us    relay/ros/cdr.py 4.4 us
    geometry_msgs/PoseStamped    rclpy 31 us    rosbags 10 us    relay/ros/cdr.py ~4 us
    sensor_msgs/LaserScan (360)  rclpy 14 us    rosbags 7.6 us
    sensor_msgs/Image 640x480    rclpy 242 us   rosbags 79 us (the pixels not copied)

**Batches.** ``loop.call_soon_threadsafe`` per message costs a wake-up of the loop (a write to its self-pipe and a
pass through the selector) for each: at thousands of poses a second that was most of the relay's ingest.
:class:`Inbox` takes events from the receiving thread and wakes the loop once for everything that arrived until the
loop gets to it, and at most once every :data:`BATCH_INTERVAL` (an idle relay still delivers a lone message at
once; a busy one every 2 ms: without the floor, a loop quicker than the messages woke for each of them, 4000
wake-ups a second for 100 robots at 30 Hz + 10 Hz scans). While it waits, a robot's newer pose replaces its older
one (the hub would send only the newest anyway: a pose is state); every other event is kept in order, up to
:data:`INBOX_LIMIT`, past which the oldest are dropped and counted (a loop stalled that long has bigger problems,
and memory must stay bounded).
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
from typing import Any

from ..fleet.events import Event, PoseEvent
from ..ros.cdr import stamped_pose

logger = logging.getLogger(__name__)

#: Events other than poses that may wait for the loop; past it the oldest go (counted in ``dropped``).
INBOX_LIMIT = 10_000
#: Seconds between two deliveries at least (what a pose may wait for others to join its batch).
BATCH_INTERVAL = 0.002


class Inbox:
    """Events from a receiving thread (rclpy's executor, Zenoh's callbacks, a worker) to the loop, one wake-up per
    batch.

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
    Nav2's action: relay/ros/nav2_types.py)."""

    def __init__(self) -> None:
        from ..ros.nav2_types import typestore

        self._store = typestore()

    def __call__(self, data: bytes | memoryview, type_name: str) -> Any:
        """The message, with rclpy's attribute names; ValueError (naming the type) when the bytes are not one."""
        try:
            return self._store.deserialize_cdr(data, type_name)
        except Exception as exc:  # rosbags raises struct, index, unicode and its own errors on corrupt bytes
            raise ValueError(f"undecodable {type_name} ({len(data)} bytes): {exc}") from None
