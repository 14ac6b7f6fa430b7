"""Fan-out from the backend to every client, with bounded memory per client.

Each message is encoded once by the caller; the hub hands the *same bytes object* to every interested
client. Per client there are three lanes, drained by one writer task:

- **priority**: ``ack``, ``error``, ``estop``, ``hello`` and snapshot replies, in order. They overtake
  everything. A client that lets more than ``max_priority`` of them pile up is not reading its own replies
  and is disconnected (close code 1008) rather than buffered without bound.
- **state**: latest-value coalescing keyed by what the value describes (``robot1/pose``,
  ``robot1/sensor/gas``, ``robot1/status``): a slow client gets the newest value, never a backlog.
- **frames**: camera frames, at most ``max_frames`` queued; the oldest is dropped first. JPEG frames stand
  alone, so dropping one costs nothing but itself.
- **video**: H.264 packets, at most ``max_video`` queued (a second at 30 fps; a P-frame is a few kB). A packet
  needs every one before it back to a keyframe, so nothing is dropped from the middle: when the lane is full,
  the new packet is dropped and that stream takes nothing more until its next keyframe (the caller asks its
  encoder for one). A client that starts a video stream also waits for a keyframe. JPEG and video take turns.
- **map**: the live 3D map's blocks (relay/station/map_lane.py), one batch at most, sent when every other lane is
  empty.

The writer awaits each send, so a client that stops reading blocks only its own writer (aiohttp waits for
the socket to drain past its high-water mark) while the lanes above keep its memory bounded. The server keeps
that high-water mark and the kernel's unsent bytes small (``relay.net.server.bound_backlog``), so the lanes, not
the socket, are where a slow client's pictures wait and are dropped.

**Batching** (a client that connects with ``/ws?batch=1``): when the writer gets the socket it takes everything
waiting in the state lane and sends it as one text frame, a JSON array of the messages' bytes joined with commas
(each message already encoded once, never re-encoded). Alone when the relay is idle (one waiting message goes
out as itself: no added latency), many when it is busy: at 100 robots x 20 clients at 30 Hz that is 60 k sends a
second one by one, a few hundred batched (docs/benchmarks.md). Priority messages and camera frames are never
batched. Clients that do not ask get one message per frame, as protocol v1 always did.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Protocol

from ..session.protocol import take_frame
from .map_lane import MapLane

logger = logging.getLogger(__name__)

#: Close code for a client that does not read its own replies (RFC 6455: policy violation).
CLOSE_NOT_READING = 1008
#: A batch holds at most this many messages and stops growing past this many bytes (a browser parses one text
#: frame at a time: a megabyte of JSON in one piece would hold its main thread for tens of milliseconds).
MAX_BATCH_MESSAGES = 1000
MAX_BATCH_BYTES = 256 * 1024


class Transport(Protocol):
    """What the hub needs from a connection: send pre-encoded frames, and close it."""

    async def send_text(self, data: bytes) -> None: ...

    async def send_binary(self, data: bytes) -> None: ...

    async def close(self, code: int, reason: str) -> None: ...


@dataclass
class Counters:
    """Totals since start, exported by /metrics."""

    messages_in: int = 0
    messages_out: int = 0
    bytes_out: int = 0
    state_coalesced: int = 0  # state values replaced by a newer one before they were sent
    state_batched: int = 0  # state messages that went out in a batch of more than one
    batches: int = 0  # text frames that carried more than one message
    frames_dropped: int = 0  # camera frames dropped because a client's frame lane was full
    video_dropped: int = 0  # video packets not queued: a full video lane, or waiting for a keyframe after one
    clients_total: int = 0
    clients_dropped: int = 0  # clients disconnected for not reading


class Channel:
    """One client's lanes and its writer task."""

    def __init__(
        self,
        client_id: str,
        transport: Transport,
        counters: Counters,
        *,
        max_frames: int,
        max_priority: int,
        max_video: int = 30,
        batch: bool = False,
    ) -> None:
        self.client_id = client_id
        #: Whether the state lane goes out in batches (the client asked with ``/ws?batch=1``).
        self.batch = batch
        self.transport = transport
        self._counters = counters
        self._max_priority = max_priority
        self._priority: deque[tuple[bool, bytes]] = deque()
        self._state: dict[str, bytes] = {}
        self._frames: deque[bytes] = deque(maxlen=max_frames)
        self._video: deque[bytes] = deque()
        self._max_video = max_video
        #: Video streams that take nothing until their next keyframe (just started, or a packet was dropped).
        self._broken: set[str] = set()
        self._wake = asyncio.Event()
        self._frames_next = False  # alternate state and frames so neither starves the other
        self._video_next = False  # and, within the frames' turn, JPEG and video
        self._task: asyncio.Task[None] | None = None
        self.closed = False
        #: camera identifier -> (requested fps, loop time its next JPEG frame is due)
        self.streams: dict[str, tuple[float, float]] = {}
        #: camera identifier -> codec of this client's stream of it ("jpeg" or "h264")
        self.codecs: dict[str, str] = {}
        #: The live 3D map's blocks (relay/station/map_lane.py): sent when every other lane is empty.
        self.map = MapLane()

    # -- lanes ------------------------------------------------------------------------------------

    def put_priority(self, data: bytes, *, binary: bool = False) -> None:
        if self.closed:
            return
        if len(self._priority) >= self._max_priority:
            logger.warning("client %s does not read its replies; disconnecting it", self.client_id)
            self._counters.clients_dropped += 1
            self.closed = True
            self._priority.clear()
            self._state.clear()
            self._frames.clear()
            self._video.clear()
            self.map.clear()
            asyncio.get_running_loop().create_task(
                self.transport.close(CLOSE_NOT_READING, "client is not reading its replies")
            )
            return
        self._priority.append((binary, data))
        self._wake.set()

    def put_state(self, key: str, data: bytes) -> None:
        if self.closed:
            return
        if key in self._state:
            self._counters.state_coalesced += 1
        # Assigning to an existing key keeps its place in the dict, so a value updated at 30 Hz is not
        # pushed behind the others forever.
        self._state[key] = data
        self._wake.set()

    def put_frame(self, data: bytes) -> None:
        if self.closed:
            return
        if len(self._frames) == self._frames.maxlen:
            self._counters.frames_dropped += 1
        self._frames.append(data)
        self._wake.set()

    def put_video(self, identifier: str, data: bytes, keyframe: bool) -> bool:
        """One packet of video stream ``identifier``; False when the stream waits for a keyframe (ask for one)."""
        if self.closed:
            return True
        if identifier in self._broken:
            if not keyframe:
                self._counters.video_dropped += 1
                return False
            self._broken.discard(identifier)
        if len(self._video) >= self._max_video:
            self._counters.video_dropped += 1
            self._broken.add(identifier)
            return False
        self._video.append(data)
        self._wake.set()
        return True

    def put_map(self, frames: list[tuple[bool, bytes]], version: int) -> bool:
        """A batch of the 3D map's frames bringing the client to ``version``; False while the last one waits."""
        if self.closed or not self.map.put(frames, version):
            return False
        self._wake.set()
        return True

    def start_video(self, identifier: str) -> None:
        """A video stream starts (or restarts): a decoder needs a keyframe first."""
        self._broken.add(identifier)

    @property
    def queued(self) -> int:
        return len(self._priority) + len(self._state) + len(self._frames) + len(self._video) + len(self.map)

    def _next(self) -> tuple[bool, bytes, int] | None:
        """The next frame to send: (binary, bytes, how many messages it carries)."""
        if self._priority:
            binary, data = self._priority.popleft()
            return binary, data, 1
        take_frame = bool(self._frames or self._video) and (self._frames_next or not self._state)
        if take_frame:
            self._frames_next = False
            self._video_next = not self._video_next
            lane = self._video if self._video and (self._video_next or not self._frames) else self._frames
            return True, lane.popleft(), 1
        if self._state:
            self._frames_next = True
            if self.batch and len(self._state) > 1:
                return False, *self._take_batch()
            key = next(iter(self._state))
            return False, self._state.pop(key), 1
        if self.map:
            return *self.map.pop(), 1
        return None

    def _take_batch(self) -> tuple[bytes, int]:
        """The oldest waiting state messages as one JSON array (their bytes joined, not re-encoded)."""
        state = self._state
        taken: list[bytes] = []
        size = 0
        for key in state:
            data = state[key]
            taken.append(data)
            size += len(data) + 1
            if len(taken) >= MAX_BATCH_MESSAGES or size >= MAX_BATCH_BYTES:
                break
        if len(taken) == len(state):
            state.clear()
        else:
            for key in list(state)[: len(taken)]:
                del state[key]
        if len(taken) == 1:
            return taken[0], 1
        self._counters.batches += 1
        self._counters.state_batched += len(taken)
        return b"[" + b",".join(taken) + b"]", len(taken)

    # -- writer -----------------------------------------------------------------------------------

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name=f"writer-{self.client_id}")

    async def _run(self) -> None:
        while not self.closed:
            await self._wake.wait()
            self._wake.clear()
            sent = 0
            while not self.closed and (item := self._next()) is not None:
                binary, data, count = item
                sent += 1
                if sent % 64 == 0:
                    # aiohttp returns without suspending until its buffer passes 64 kB: on a fast socket a
                    # long backlog would otherwise go out in one step while every other client waits.
                    await asyncio.sleep(0)
                try:
                    if binary:
                        await self.transport.send_binary(data)
                    else:
                        await self.transport.send_text(data)
                except (ConnectionError, RuntimeError) as exc:
                    # The peer went away mid-send; the server's reader notices and removes the client.
                    logger.debug("send to %s failed: %s", self.client_id, exc)
                    self.closed = True
                    return
                self._counters.messages_out += count
                self._counters.bytes_out += len(data)

    async def stop(self) -> None:
        self.closed = True
        self._wake.set()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task


class Hub:
    """Routes encoded messages to client channels."""

    def __init__(self, *, max_frames: int = 2, max_priority: int = 1024, max_video: int = 30) -> None:
        self.counters = Counters()
        self._channels: dict[str, Channel] = {}
        self._max_frames = max_frames
        self._max_video = max_video
        self._max_priority = max_priority

    def __len__(self) -> int:
        return len(self._channels)

    def __iter__(self) -> Iterator[Channel]:
        return iter(list(self._channels.values()))

    def add(self, client_id: str, transport: Transport, *, batch: bool = False) -> Channel:
        channel = Channel(
            client_id,
            transport,
            self.counters,
            max_frames=self._max_frames,
            max_priority=self._max_priority,
            max_video=self._max_video,
            batch=batch,
        )
        self._channels[client_id] = channel
        self.counters.clients_total += 1
        channel.start()
        return channel

    async def remove(self, channel: Channel) -> None:
        self._channels.pop(channel.client_id, None)
        await channel.stop()

    def publish_state(self, key: str, data: bytes) -> None:
        """Latest-value state (pose, sensor, status) to every client."""
        for channel in self._channels.values():
            channel.put_state(key, data)

    def broadcast_priority(self, data: bytes) -> None:
        """A message that must overtake everything, to every client (e.g. an emergency stop)."""
        for channel in list(self._channels.values()):
            channel.put_priority(data)

    def publish_frame(self, identifier: str, data: bytes, now: float) -> int:
        """A JPEG camera frame to every client streaming ``identifier`` as JPEG, throttled to each client's rate.

        Returns how many clients took it.
        """
        taken = 0
        for channel in self._channels.values():
            stream = channel.streams.get(identifier)
            if stream is None or channel.codecs.get(identifier, "jpeg") != "jpeg":
                continue
            fps, due = stream
            after = take_frame(now, due, fps)
            if after is not None:
                channel.streams[identifier] = (fps, after)
                channel.put_frame(data)
                taken += 1
        return taken

    def publish_video(self, identifier: str, data: bytes, keyframe: bool) -> tuple[int, int]:
        """A video packet to every client streaming ``identifier`` as H.264 (every packet: a video's frames cannot
        be skipped one by one). Returns how many clients stream it so, and how many of them wait for a keyframe."""
        viewers = waiting = 0
        for channel in self._channels.values():
            if channel.codecs.get(identifier) == "h264" and identifier in channel.streams:
                viewers += 1
                waiting += not channel.put_video(identifier, data, keyframe)
        return viewers, waiting

    def set_stream(self, channel: Channel, identifier: str, fps: float, codec: str = "jpeg") -> None:
        if fps <= 0:
            channel.streams.pop(identifier, None)
            channel.codecs.pop(identifier, None)
        else:
            if codec == "h264" and channel.codecs.get(identifier) != "h264":
                channel.start_video(identifier)
            channel.streams[identifier] = (fps, -math.inf)  # (rate, when its next frame is due)
            channel.codecs[identifier] = codec

    def stream_demand(self, identifier: str, codec: str | None = None) -> float:
        """The highest rate any client wants ``identifier`` at, in ``codec`` or any (0 when nobody streams it)."""
        return max(
            (
                c.streams[identifier][0]
                for c in self._channels.values()
                if identifier in c.streams and (codec is None or c.codecs.get(identifier, "jpeg") == codec)
            ),
            default=0.0,
        )
