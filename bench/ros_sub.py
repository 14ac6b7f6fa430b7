"""Bare rclpy subscribers to nav_msgs/Odometry: the limit the relay's ros backend is measured against, and
the executor and decoding options it could use.

    python -m bench.ros_sub --topic /r1/odom --variants plain-single,raw-events,... [--duration 4]

A variant is ``<decode>-<executor>``:

- decode ``plain``: rclpy deserialises the message (what the ros backend does); the callback reads the
  stamp and the pose, as ``relay.backends.ingest.pose_reader`` does;
- ``raw``: ``raw=True``, the callback gets the CDR bytes and reads only the stamp (the least any
  subscriber does: the ceiling);
- ``rawcdr``: ``raw=True`` and bench/cdr.py's hand-written decode of the stamp, frame and pose; the first
  messages are also deserialised by rclpy and compared (a wrong decode fails the variant);
- executor ``single``: rclpy.executors.SingleThreadedExecutor (the backend's); ``events``:
  rclpy.experimental.EventsExecutor.

Every variant has its own context, node and executor, spun in a thread as the backend spins its own, with
the backend's QoS (best effort, depth 10). After the window it checks what the backend needs besides
speed: a subscription created and one destroyed from another thread while the executor spins (the
backend's on-demand cameras). Prints one JSON line per variant.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import rclpy
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rclpy.task import Future

from .cdr import odometry_pose, odometry_stamp, verify

#: Messages of a rawcdr variant checked against rclpy's deserialisation.
VERIFY_FIRST = 50


def emit(record: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(record) + "\n")
    sys.stdout.flush()


@dataclass
class Tally:
    count: int = 0
    active: bool = False
    latencies: list[float] = field(default_factory=list)
    first: threading.Event = field(default_factory=threading.Event)
    verified: int = 0
    mismatch: str | None = None


def callback(decode: str, tally: Tally) -> Any:
    if decode == "plain":

        def on_message(message: Any) -> None:
            now = time.monotonic()
            stamp = message.header.stamp
            pose = message.pose.pose
            p, q = pose.position, pose.orientation
            # The same reads as relay.backends.ingest.pose_reader: the pose fields become a PoseEvent there.
            _ = (message.header.frame_id, p.x, p.y, p.z, q.x, q.y, q.z, q.w)
            tally.count += 1
            if tally.active:
                tally.latencies.append(now - (stamp.sec + stamp.nanosec * 1e-9))
            tally.first.set()

        return on_message
    if decode == "raw":

        def on_raw(data: bytes) -> None:
            now = time.monotonic()
            tally.count += 1
            if tally.active:
                tally.latencies.append(now - odometry_stamp(data))
            tally.first.set()

        return on_raw

    def on_cdr(data: bytes) -> None:
        now = time.monotonic()
        pose = odometry_pose(data)
        tally.count += 1
        if tally.verified < VERIFY_FIRST:
            check(data, pose, tally)
        if tally.active:
            tally.latencies.append(now - pose.stamp)
        tally.first.set()

    return on_cdr


def check(data: bytes, pose: Any, tally: Tally) -> None:
    message = deserialize_message(data, Odometry)
    p, q = message.pose.pose.position, message.pose.pose.orientation
    expected = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    stamp = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
    got = (pose.x, pose.y, pose.z, pose.qx, pose.qy, pose.qz, pose.qw)
    if got != expected or not math.isclose(pose.stamp, stamp, abs_tol=1e-9):
        tally.mismatch = f"decoded {pose} but rclpy says {expected} at {stamp}"
    tally.verified += 1


def make_executor(name: str, context: Context) -> Any:
    if name == "events":
        from rclpy.experimental.events_executor import EventsExecutor

        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def run_variant(topic: str, variant: str, warmup: float, duration: float, first_timeout: float) -> dict[str, Any]:
    decode, executor_name = variant.split("-")
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node(f"bench_sub_{decode}_{executor_name}", context=context)
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    tally = Tally()
    node.create_subscription(Odometry, topic, callback(decode, tally), qos, raw=decode in ("raw", "rawcdr"))
    executor = make_executor(executor_name, context)
    executor.add_node(node)
    errors: list[str] = []
    stop: Future[None] = Future()

    def spin() -> None:
        try:
            if executor_name == "events":
                # EventsExecutor.spin() and spin_once() dispatch nothing when called from a thread other
                # than the main one in this rclpy (9.1.2, PyPI wheels), and its shutdown() then blocks
                # for ever; spin_until_future_complete works, so it spins until this future is done.
                while context.ok() and not stop.done():
                    executor.spin_until_future_complete(stop, timeout_sec=1.0)
            else:
                executor.spin()
        except Exception as exc:  # shutdown under it ends spin with an exception in some rclpy versions
            if context.ok():
                errors.append(repr(exc))

    thread = threading.Thread(target=spin, name="executor", daemon=True)
    thread.start()
    result: dict[str, Any] = {"variant": variant, "decode": decode, "executor": executor_name}
    try:
        if not tally.first.wait(first_timeout):
            result["error"] = f"no message within {first_timeout} s"
            return result
        time.sleep(warmup)
        tally.active = True
        c0, t0, cpu0 = tally.count, time.monotonic(), time.process_time()
        time.sleep(duration)
        c1, t1, cpu1 = tally.count, time.monotonic(), time.process_time()
        tally.active = False
        latencies = sorted(tally.latencies)
        n = len(latencies)
        result.update(
            {
                "rate": round((c1 - c0) / (t1 - t0), 1),
                "cpu": round((cpu1 - cpu0) / (t1 - t0), 3),
                "latency_ms": {
                    "n": n,
                    "p50": round(1000 * latencies[n // 2], 3) if n else None,
                    "p99": round(1000 * latencies[min(n - 1, int(0.99 * n))], 3) if n else None,
                },
                "verified": tally.verified,
                "mismatch": tally.mismatch,
            }
        )
        result["late_subscription"] = late_subscription(node, topic, qos)
    finally:
        stop.set_result(None)
        if executor_name == "events":
            thread.join(3.0)
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        thread.join(3.0)
        if errors:
            result["spin_errors"] = errors
    return result


def late_subscription(node: Any, topic: str, qos: QoSProfile) -> str:
    """Create, use and destroy a subscription from this thread while the executor spins in its own, as the
    backend's on-demand camera subscriptions do. "ok" or what went wrong."""
    got = threading.Event()
    try:
        late = node.create_subscription(Odometry, topic, lambda _m: got.set(), qos)
        if not got.wait(5.0):
            return "a subscription created while spinning got no message within 5 s"
        node.destroy_subscription(late)
        time.sleep(0.2)  # a destroyed subscription must not take the executor down with it
        return "ok"
    except Exception as exc:
        return f"failed: {exc!r}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--topic", default="/r1/odom")
    parser.add_argument("--variants", default="plain-single,raw-single")
    parser.add_argument("--warmup", type=float, default=0.5)
    parser.add_argument("--duration", type=float, default=4.0)
    parser.add_argument("--first-timeout", type=float, default=20.0)
    args = parser.parse_args()
    if "rawcdr" in args.variants:
        # The hand-written decode against rclpy's serializer, every alignment of the frame ids, before use.
        emit({"cdr_verified": verify(64)})
    for variant in args.variants.split(","):
        emit(run_variant(args.topic, variant, args.warmup, args.duration, args.first_timeout))
    emit({"done": True})
    return 0


if __name__ == "__main__":
    sys.exit(main())
