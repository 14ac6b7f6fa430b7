"""The 3D map's lane (issue #33): the lowest priority, and one batch at most per client, without sockets."""

from __future__ import annotations

from relay.station.hub import Hub
from tests.helpers.hub import RecordingTransport, settle


async def test_poses_and_estop_go_before_map_frames() -> None:
    hub = Hub()
    stalled = RecordingTransport(paused=True)
    channel = hub.add("c1", stalled)
    await settle()
    batch = [(False, b"map"), (True, b"XRVB1"), (True, b"XRVB2")]
    assert channel.put_map(batch, 7)
    channel.put_state("robot1/pose", b"pose")
    channel.put_priority(b"estop")
    stalled.gate.set()
    await settle()
    assert [data for _, data in stalled.sent] == [b"estop", b"pose", b"map", b"XRVB1", b"XRVB2"]
    assert [kind for kind, _ in stalled.sent[2:]] == ["text", "binary", "binary"]


async def test_a_pose_overtakes_the_rest_of_a_batch() -> None:
    hub = Hub()
    transport = RecordingTransport(paused=True)
    channel = hub.add("c1", transport)
    await settle()
    channel.put_map([(True, bytes([i])) for i in range(4)], 3)
    transport.gate.set()
    await settle()
    assert len(transport.sent) == 4
    transport.gate.clear()
    channel.put_map([(True, b"a"), (True, b"b"), (True, b"c")], 4)
    await settle()  # the writer waits in the send of "a"
    channel.put_state("robot1/pose", b"pose")
    transport.gate.set()
    await settle()
    assert [data for _, data in transport.sent[4:]] == [b"a", b"pose", b"b", b"c"]


async def test_one_batch_at_most_waits() -> None:
    hub = Hub()
    stalled = RecordingTransport(paused=True)
    channel = hub.add("c1", stalled)
    await settle()
    assert channel.put_map([(False, b"h"), (True, b"XRVB")], 1)
    await settle()
    assert not channel.put_map([(False, b"h2")], 2)  # the first is still waiting (one frame in the writer's send)
    assert channel.map.version == 1
    assert channel.queued <= 2
    stalled.gate.set()
    await settle()
    assert channel.map.idle
    assert channel.put_map([(False, b"h2")], 2)
