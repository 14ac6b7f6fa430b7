"""The ros backend's intake (relay/backends/ingest.py, relay/ros/cdr.py, relay/backends/ros_spinner.py): the inbox that
hands events to the loop in batches, the raw decoders, and the executor that spins from a thread and stops when
asked, whatever happened while it spun. Real threads, a real asyncio loop, real rclpy where the test needs it
(skipped without it)."""

from __future__ import annotations

import asyncio
import itertools
import logging
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from relay.backends.ingest import BATCH_INTERVAL, INBOX_LIMIT, Inbox, RawDecoder, pose_reader
from relay.backends.ros_spinner import Spinner
from relay.config import parse_config
from relay.fleet.events import Event, PoseEvent, ScanEvent, SensorEvent
from relay.ros.tf import TfPose
from tests.conftest import LOAD_SLACK


def _pose(robot: str, x: float) -> PoseEvent:
    return PoseEvent(robot, 1.0, "map", x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


async def test_the_inbox_wakes_the_loop_once_per_batch_and_keeps_each_robots_newest_pose() -> None:
    loop = asyncio.get_running_loop()
    delivered: list[Event] = []
    inbox = Inbox(loop, delivered.append)
    wakeups = 0
    drain = inbox._drain

    def counted_drain() -> None:
        nonlocal wakeups
        wakeups += 1
        drain()

    inbox._drain = counted_drain  # type: ignore[method-assign]

    def executor_thread() -> None:  # what the ROS executor does: many messages while the loop is busy
        for i in range(500):
            inbox.put(_pose("r1", float(i)))
            inbox.put(_pose("r2", float(-i)))
            if i % 100 == 0:
                inbox.put(SensorEvent("r1", "gas", float(i), 1.0))

    thread = threading.Thread(target=executor_thread)
    thread.start()
    thread.join()  # the loop has not run meanwhile: one batch waits
    await asyncio.sleep(0.05)
    assert wakeups == 1
    poses = [e for e in delivered if isinstance(e, PoseEvent)]
    assert [(p.robot, p.x) for p in poses] == [("r1", 499.0), ("r2", -499.0)]  # the newest of each
    assert [e.value for e in delivered if isinstance(e, SensorEvent)] == [0.0, 100.0, 200.0, 300.0, 400.0]  # in order
    assert inbox.stats() == {"received": 1005, "coalesced": 998, "dropped": 0}
    # An idle relay: a lone pose is delivered at once, by itself.
    inbox.put(_pose("r1", 7.0))
    await asyncio.sleep(0.02)
    assert wakeups == 2 and delivered[-1] == _pose("r1", 7.0)


async def test_a_busy_inbox_delivers_at_most_once_per_batch_interval() -> None:
    loop = asyncio.get_running_loop()
    delivered: list[Event] = []
    inbox = Inbox(loop, delivered.append)
    drains: list[float] = []
    drain = inbox._drain

    def timed_drain() -> None:
        drains.append(loop.time())
        drain()

    inbox._drain = timed_drain  # type: ignore[method-assign]
    stop = threading.Event()

    put: list[int] = []

    def executor_thread() -> None:  # 100 robots, a pose every 0.1 ms
        i = 0
        while not stop.is_set():
            inbox.put(_pose(f"r{i % 100}", float(i)))
            i += 1
            put.append(i)
            time.sleep(0.0001)

    thread = threading.Thread(target=executor_thread)
    thread.start()
    await asyncio.sleep(0.3)
    # Every robot twice at least, however slowly a loaded machine runs the thread.
    deadline = time.monotonic() + 30
    while len(put) < 200 and time.monotonic() < deadline:  # noqa: ASYNC110 - a thread's count, not an event
        await asyncio.sleep(0.05)
    stop.set()
    thread.join()
    # The last drain (at most a batch interval after the last put, later when the loop waits for a CPU).
    while inbox.stats()["received"] - 1 not in {p.x for p in delivered[-100:] if isinstance(p, PoseEvent)}:
        assert time.monotonic() < deadline, "the last pose was never delivered"
        await asyncio.sleep(0.02)
    gaps = [b - a for a, b in itertools.pairwise(drains)]
    assert len(drains) > 10 and min(gaps) >= BATCH_INTERVAL - 1e-6
    newest = {p.robot: p.x for p in delivered if isinstance(p, PoseEvent)}
    assert len(newest) == 100 and max(newest.values()) == inbox.stats()["received"] - 1  # the last one arrived


async def test_the_inbox_is_bounded_while_the_loop_is_stalled() -> None:
    delivered: list[Event] = []
    inbox = Inbox(asyncio.get_running_loop(), delivered.append)
    for i in range(INBOX_LIMIT + 25):
        inbox.put(SensorEvent("r1", "gas", float(i), 1.0))
    await asyncio.sleep(0.02)
    values = [e.value for e in delivered if isinstance(e, SensorEvent)]
    assert len(values) == INBOX_LIMIT and values[0] == 25.0 and values[-1] == float(INBOX_LIMIT + 24)
    assert inbox.stats()["dropped"] == 25


def test_an_inbox_whose_loop_has_closed_takes_events_without_raising() -> None:
    loop = asyncio.new_event_loop()
    inbox = Inbox(loop, lambda event: None)
    loop.close()
    inbox.put(_pose("r1", 1.0))  # shutdown: the executor's last messages have nowhere to go, quietly
    assert inbox.stats()["received"] == 1


def test_pose_messages_decode_by_hand_exactly_as_rclpy_serialises_them() -> None:
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'`")
    from relay.ros.cdr import verify

    assert verify(40) == 120  # Odometry, PoseStamped, PoseWithCovarianceStamped; every alignment of the frame ids


def test_a_pose_without_stamp_or_frame_gets_the_receive_time_and_map() -> None:
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'`")
    from geometry_msgs.msg import PoseStamped
    from rclpy.serialization import serialize_message

    message = PoseStamped()
    message.pose.position.x = 2.5
    got: list[Event] = []
    before = time.time()
    pose_reader("r1", child_frame=False, put=got.append)(serialize_message(message))
    (pose,) = got
    assert isinstance(pose, PoseEvent) and pose.x == 2.5 and pose.frame == "map" and before <= pose.stamp <= time.time()


def test_corrupt_pose_bytes_are_logged_with_the_robot_and_nothing_is_posted(caplog: pytest.LogCaptureFixture) -> None:
    got: list[Event] = []
    reader = pose_reader("r7", child_frame=True, put=got.append)
    with caplog.at_level(logging.WARNING):
        reader(b"\x00\x01\x00\x00" + bytes(6))  # an Odometry cut short
        reader(b"\x00\x09" + bytes(60))  # not CDR
    assert got == []
    assert [r.getMessage().split(":")[0] for r in caplog.records] == ["r7", "r7"]


def _tf_bytes(store: Any, transforms: list[tuple[str, str, float, float]]) -> bytes:
    types = store.types
    Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    Vector3, Quaternion = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Quaternion"]
    Transform, Stamped = types["geometry_msgs/msg/Transform"], types["geometry_msgs/msg/TransformStamped"]
    message = types["tf2_msgs/msg/TFMessage"](
        transforms=[
            Stamped(
                header=Header(stamp=Time(sec=100, nanosec=0), frame_id=parent),
                child_frame_id=child,
                transform=Transform(
                    translation=Vector3(x=x, y=y, z=0.0), rotation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
                ),
            )
            for parent, child, x, y in transforms
        ]
    )
    return bytes(store.serialize_cdr(message, "tf2_msgs/msg/TFMessage"))


async def test_raw_tf_composes_the_robots_pose_and_corrupt_tf_or_scans_change_nothing(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """TF and LaserScan arrive raw and are decoded by rosbags (no tf2_msgs needed to read them)."""
    from relay.backends.ros import RosBackend
    from relay.ros.ros_env import typestore

    config = parse_config(
        "robots:\n  - name: t1\n    pose: {source: tf}\n    limits: {linear: 0.5, angular: 1.0}\n", "fleet.yaml"
    )
    events: list[Event] = []
    backend = RosBackend(config, events.append)
    backend._inbox = Inbox(asyncio.get_running_loop(), events.append)
    backend._tf["t1"] = TfPose("map", "odom", "base_link")
    store = typestore()
    backend._on_tf("t1", _tf_bytes(store, [("map", "odom", 1.0, 2.0), ("odom", "base_link", 0.5, 0.25)]))
    await asyncio.sleep(0.02)
    (pose,) = [e for e in events if isinstance(e, PoseEvent)]
    assert (pose.robot, pose.frame, pose.x, pose.y, pose.stamp) == ("t1", "map", 1.5, 2.25, 100.0)
    with caplog.at_level(logging.WARNING):
        backend._on_tf("t1", b"\x00\x01\x00\x00\xff\xff\xff\x7f")  # a sequence length far past the bytes
        backend._on_scan("t1", b"\x00\x01\x00\x00" + bytes(3))
    await asyncio.sleep(0.02)
    assert len(events) == 1
    messages = [r.getMessage() for r in caplog.records]
    assert any("tf2_msgs/msg/TFMessage" in m and m.startswith("t1") for m in messages), messages
    assert any("sensor_msgs/msg/LaserScan" in m and m.startswith("t1") for m in messages), messages


async def test_a_raw_laser_scan_becomes_a_scan_event() -> None:
    from relay.backends.ros import RosBackend
    from relay.ros.ros_env import typestore

    config = parse_config("robots:\n  - name: s1\n    limits: {linear: 0.5, angular: 1.0}\n", "fleet.yaml")
    events: list[Event] = []
    backend = RosBackend(config, events.append)
    backend._inbox = Inbox(asyncio.get_running_loop(), events.append)
    store = typestore()
    types = store.types
    import numpy as np

    stamp = types["builtin_interfaces/msg/Time"](sec=5, nanosec=0)
    scan = types["sensor_msgs/msg/LaserScan"](
        header=types["std_msgs/msg/Header"](stamp=stamp, frame_id="laser"),
        angle_min=-1.0, angle_max=1.0, angle_increment=0.5, time_increment=0.0, scan_time=0.1,
        range_min=0.1, range_max=8.0,
        ranges=np.array([1.0, 0.05, 9.0, 2.0, 3.0], dtype=np.float32), intensities=np.zeros(0, dtype=np.float32),
    )  # fmt: skip
    backend._on_scan("s1", bytes(store.serialize_cdr(scan, "sensor_msgs/msg/LaserScan")))
    await asyncio.sleep(0.02)
    (event,) = events
    assert isinstance(event, ScanEvent) and event.frame == "laser" and event.stamp == 5.0
    assert event.ranges[0] == 1.0 and event.ranges[3:] == (2.0, 3.0)
    assert all(r != r for r in event.ranges[1:3])  # out of range: NaN, no return


def test_the_raw_decoder_names_the_type_of_bytes_it_cannot_read() -> None:
    with pytest.raises(ValueError, match="sensor_msgs/msg/Image"):
        RawDecoder()(b"\x00\x01\x00\x00" + bytes(5), "sensor_msgs/msg/Image")


@pytest.mark.ros
@pytest.mark.parametrize("kind", ["events", "single"])
def test_the_executor_spins_from_a_thread_takes_late_subscriptions_and_stops(kind: str, ros_domain: int) -> None:
    """Subscriptions made and destroyed while it spins (the cameras, on demand), then a bounded stop: the
    EventsExecutor of this rclpy hangs for ever if spun with spin() from a thread or shut down while spinning."""
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'`")
    import rclpy
    import rclpy.executors
    from rclpy.context import Context
    from std_msgs.msg import String

    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("ingest_test", context=context)
    failures: list[str] = []
    spinner = Spinner(rclpy.executors, context, kind, failures.append)
    spinner.start(node)
    publisher = node.create_publisher(String, "/late", 10)
    try:
        for round_ in range(3):  # subscribe, receive, destroy: three times while spinning
            got = threading.Event()
            subscription = node.create_subscription(String, "/late", lambda _m, g=got: g.set(), 10, raw=True)
            # Discovery of the new subscription takes a few ms on a quiet machine; 30 s bounds a loaded one.
            deadline = time.monotonic() + 30
            while not got.is_set() and time.monotonic() < deadline:
                publisher.publish(String(data=f"round {round_}"))
                got.wait(0.05)
            assert got.is_set(), f"round {round_}: a subscription made while spinning got nothing in 30 s"
            node.destroy_subscription(subscription)
        started = time.monotonic()
        spinner.stop(timeout=3.0)
        # Bounded: the executor's shutdown (1 s at most) and the join (3 s), and what a loaded machine adds.
        assert time.monotonic() - started < 1.0 + 3.0 + LOAD_SLACK
        assert failures == []
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def test_the_scan_cap_passes_a_jittery_stream_at_its_rate_and_caps_a_faster_one() -> None:
    from relay.fleet.scan import RateCap

    rng = __import__("random").Random(5)
    cap = RateCap(10.0)
    # A 10 Hz laser whose scans arrive up to 30 ms early or late: every one passes.
    times = [0.1 * k + rng.uniform(-0.03, 0.03) for k in range(200)]
    assert sum(cap.allow("r1", t) for t in times) == 200
    # A 30 Hz laser: 10 a second pass, evenly.
    passed = [t for t in (k / 30 for k in range(600)) if cap.allow("r2", t)]
    assert 199 <= len(passed) <= 201
    assert max(b - a for a, b in itertools.pairwise(passed)) < 0.11
    # A burst after a silence builds no backlog: at most the credit of two periods, then the rate again.
    burst = [100.0 + 0.001 * k for k in range(50)]
    assert sum(cap.allow("r1", t) for t in burst) <= 3
