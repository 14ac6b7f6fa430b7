"""The hub: encode once, coalesce state, bound frames, let priority overtake, and cap a stalled client."""

from __future__ import annotations

import asyncio

from relay.hub import CLOSE_NOT_READING, Hub


class RecordingTransport:
    """Records what it is sent; while ``paused`` it blocks like a socket whose peer stopped reading."""

    def __init__(self, paused: bool = False) -> None:
        self.sent: list[tuple[str, bytes]] = []
        self.gate = asyncio.Event()
        if not paused:
            self.gate.set()
        self.closed: tuple[int, str] | None = None

    async def send_text(self, data: bytes) -> None:
        await self.gate.wait()
        self.sent.append(("text", data))

    async def send_binary(self, data: bytes) -> None:
        await self.gate.wait()
        self.sent.append(("binary", data))

    async def close(self, code: int, reason: str) -> None:
        self.closed = (code, reason)


async def settle() -> None:
    for _ in range(20):
        await asyncio.sleep(0)


async def test_same_bytes_object_goes_to_every_client() -> None:
    hub = Hub()
    transports = [RecordingTransport() for _ in range(3)]
    for i, t in enumerate(transports):
        hub.add(f"c{i}", t)
    data = b'{"identifier":"robot1/pose"}'
    hub.publish_state("robot1/pose", data)
    await settle()
    assert all(len(t.sent) == 1 and t.sent[0][1] is data for t in transports)
    assert hub.counters.messages_out == 3


async def test_stalled_client_gets_newest_value_not_a_backlog() -> None:
    hub = Hub()
    stalled = RecordingTransport(paused=True)
    healthy = RecordingTransport()
    channel = hub.add("stalled", stalled)
    hub.add("healthy", healthy)
    await settle()
    for i in range(5000):
        for robot in ("robot1", "robot2", "robot3"):
            hub.publish_state(f"{robot}/pose", f"{robot}:{i}".encode())
        if i % 100 == 0:
            await asyncio.sleep(0)
    # Bounded by the number of keys, not the number of updates (the writer holds at most one more).
    assert channel.queued <= 3
    assert len(healthy.sent) > 3 * 40
    stalled.gate.set()
    await settle()
    latest = {data.split(b":")[0]: data for _, data in stalled.sent}
    assert latest == {r.encode(): f"{r}:4999".encode() for r in ("robot1", "robot2", "robot3")}
    assert len(stalled.sent) <= 6
    assert hub.counters.state_coalesced > 10000


async def test_frames_are_bounded_drop_oldest_and_throttled_per_client() -> None:
    hub = Hub(max_frames=2)
    stalled = RecordingTransport(paused=True)
    channel = hub.add("s", stalled)
    hub.set_stream(channel, "robot1/camera/front", 30.0)
    await settle()
    for i in range(10):
        hub.publish_frame("robot1/camera/front", bytes([i]), now=float(i))
    assert channel.queued <= 2
    assert hub.counters.frames_dropped >= 7
    stalled.gate.set()
    await settle()
    # The writer had taken frame 0 before the stall; after it, only the two newest remain.
    assert [d for _, d in stalled.sent][-2:] == [bytes([8]), bytes([9])]
    # Throttling: a 2 fps subscriber takes one of the frames that arrive 0.1 s apart.
    slow = RecordingTransport()
    slow_channel = hub.add("slow", slow)
    hub.set_stream(slow_channel, "robot1/camera/front", 2.0)
    taken = sum(hub.publish_frame("robot1/camera/front", b"f", now=100 + i * 0.1) >= 2 for i in range(10))
    assert taken == 2
    assert hub.stream_demand("robot1/camera/front") == 30.0
    hub.set_stream(channel, "robot1/camera/front", 0)
    assert hub.stream_demand("robot1/camera/front") == 2.0


async def test_priority_overtakes_state_and_frames() -> None:
    hub = Hub()
    transport = RecordingTransport(paused=True)
    channel = hub.add("c", transport)
    hub.set_stream(channel, "cam", 30)
    await settle()
    hub.publish_state("robot1/pose", b"pose")
    hub.publish_frame("cam", b"frame", now=1.0)
    channel.put_priority(b"ack")
    hub.broadcast_priority(b"estop")
    transport.gate.set()
    await settle()
    assert [d for _, d in transport.sent] == [b"ack", b"estop", b"pose", b"frame"]


async def test_client_that_never_reads_its_replies_is_disconnected() -> None:
    hub = Hub(max_priority=10)
    transport = RecordingTransport(paused=True)
    channel = hub.add("c", transport)
    await settle()
    for _ in range(11):
        channel.put_priority(b"ack")
    await settle()
    assert transport.closed is not None and transport.closed[0] == CLOSE_NOT_READING
    assert channel.queued == 0 and hub.counters.clients_dropped == 1


async def test_remove_stops_the_writer() -> None:
    hub = Hub()
    transport = RecordingTransport(paused=True)
    channel = hub.add("c", transport)
    hub.publish_state("k", b"v")
    await settle()
    await hub.remove(channel)
    assert len(hub) == 0
    hub.publish_state("k", b"w")
    assert channel.queued == 0
