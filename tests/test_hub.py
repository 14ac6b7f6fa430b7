"""The hub: encode once, coalesce state, bound frames, let priority overtake, and cap a stalled client."""

from __future__ import annotations

import asyncio
from pathlib import Path

from relay.station.hub import CLOSE_NOT_READING, Hub
from tests.helpers.hub import RecordingTransport, settle

DOC_PROTOCOL = (Path(__file__).parent.parent / "docs/protocol.md").read_text()


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
    # Throttling: a 2 fps subscriber takes one at once, then 2 a second of the frames that arrive 0.1 s apart.
    slow = RecordingTransport()
    slow_channel = hub.add("slow", slow)
    hub.set_stream(slow_channel, "robot1/camera/front", 2.0)
    taken = sum(hub.publish_frame("robot1/camera/front", b"f", now=100 + i * 0.1) >= 2 for i in range(100))
    assert taken == 1 + 2 * 10
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


async def test_a_batching_client_gets_what_waits_in_one_json_array_and_a_lone_message_as_itself() -> None:
    from relay.station import messages

    def pose(robot: str, x: float) -> bytes:
        q = 0.707107
        o = 0.0
        message = messages.pose_message(robot, stamp=1.7e9 + 0.5, frame="map", x=x, y=1.5, z=o, qx=o, qy=o, qz=q, qw=q)
        return messages.encode(message)

    reading = messages.sensor_message("robot1", name="gas", value=5.2, unit="ppm", warning=False, stamp=1.0)
    gas = messages.encode(reading)
    hub = Hub()
    batching, plain = RecordingTransport(), RecordingTransport()
    hub.add("batching", batching, batch=True)
    hub.add("plain", plain)
    await settle()
    # Idle: one message goes out alone, as itself (no array, no added wait).
    hub.publish_state("robot1/pose", pose("robot1", 2.0))
    await settle()
    assert batching.sent == [("text", pose("robot1", 2.0))]
    # Busy: what was published before the writer ran goes out as one array, in the order first queued (robot1's
    # pose updated in place), the bytes joined as they were encoded once. Pinned, as docs/protocol.md shows it.
    batching.sent.clear()
    plain.sent.clear()
    hub.publish_state("robot1/pose", pose("robot1", 2.5))
    hub.publish_state("robot2/pose", pose("robot2", 9.0))
    hub.publish_state("robot1/sensor/gas", gas)
    hub.publish_state("robot1/pose", pose("robot1", 3.0))
    await settle()
    assert batching.sent == [
        (
            "text",
            b'[{"identifier":"robot1/pose","stamp":1700000000.5,"frame":"map","x":3.0,"y":1.5,"z":0.0,"qx":0.0,'
            b'"qy":0.0,"qz":0.707107,"qw":0.707107,"yaw":1.570797},{"identifier":"robot2/pose","stamp":1700000000.5,'
            b'"frame":"map","x":9.0,"y":1.5,"z":0.0,"qx":0.0,"qy":0.0,"qz":0.707107,"qw":0.707107,"yaw":1.570797},'
            b'{"identifier":"robot1/sensor","name":"gas","value":5.2,"unit":"ppm","warning":false,"stamp":1.0}]',
        )
    ]
    assert batching.sent[0][1].decode() in DOC_PROTOCOL.replace("\n", "")
    # A client that did not ask gets the same messages one per frame, never an array.
    assert [data[:1] for _, data in plain.sent] == [b"{"] * 3
    assert hub.counters.batches == 1 and hub.counters.state_batched == 3


async def test_batches_are_bounded_and_priority_and_frames_are_never_batched() -> None:
    from relay.station.hub import MAX_BATCH_MESSAGES

    hub = Hub()
    transport = RecordingTransport(paused=True)
    channel = hub.add("c", transport, batch=True)
    await settle()
    for i in range(MAX_BATCH_MESSAGES + 10):
        channel.put_state(f"robot{i}/pose", b"{}")
    channel.put_priority(b'{"identifier":"ack","id":1}')
    channel.put_frame(b"frame")
    transport.gate.set()
    await settle()
    kinds = [(kind, data[:1]) for kind, data in transport.sent]
    # The ack first, alone; then a full batch, the frame (state and frames alternate), and the rest.
    assert kinds == [("text", b"{"), ("text", b"["), ("binary", b"f"), ("text", b"[")]
    assert transport.sent[1][1].count(b"{}") == MAX_BATCH_MESSAGES
    assert transport.sent[3][1] == b"[" + b",".join([b"{}"] * 10) + b"]"
    assert hub.counters.messages_out == 1 + MAX_BATCH_MESSAGES + 1 + 10
