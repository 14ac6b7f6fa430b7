"""``xr-relay record``: the fleet's topics from a live ROS 2 graph into a rosbag2 MCAP bag.

    xr-relay record --out DIR [--config robots.yaml] [--duration SECONDS]

It records what robots.yaml names: each robot's pose source (with ``/tf_static`` for ``tf``), ``cmd_vel``,
``goal_pose``, sensors, scan and cameras, and the fleet's map (``ros.map_topic``). Messages are stored as the
raw CDR bytes that arrived (rclpy subscriptions with ``raw=True``: nothing is decoded or re-encoded), stamped
with their receive time as ``ros2 bag record`` does, by the rosbags MCAP writer. Each topic's connection is
declared when its first message arrives, under its ROS type name, with the message definition from rosbags'
type store and the QoS its publishers offer, so the bag replays in ``ros2 bag play`` (Jazzy or newer), in
Foxglove, and with ``xr-relay --backend bag --bag DIR``. Topics nobody publishes are left out.

Subscriptions are best effort (they match reliable and best-effort publishers alike), except the map and
static TF: reliable and transient local, so that their latched message is recorded too.

Recording stops on Ctrl-C (SIGINT), SIGTERM or after ``--duration`` seconds; the bag is closed either way.
Exit status: 0 after a recording, 2 when it cannot start (no rclpy, a bad config, DIR exists).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any, Literal

from ..config import FleetConfig, load_config
from ..errors import BackendUnavailable, ConfigError
from ..ros import rosmsg
from ..ros.ros_env import load_rclpy, typestore

logger = logging.getLogger(__name__)

EXIT_USAGE = 2
#: Queue depth of the recorder's subscriptions; images keep fewer (each can be megabytes).
DEPTH = 50
IMAGE_DEPTH = 5
#: rosbag2 metadata version written: 8 is read by ``ros2 bag`` from Jazzy on (rosbags writes 8 or 9).
BAG_VERSION: Literal[8] = 8


@dataclass(frozen=True)
class RecordedTopic:
    """One topic to record: its name, its ROS type (``pkg/msg/Type``) and whether it is latched."""

    topic: str
    msgtype: str
    latched: bool = False
    image: bool = False


def topics_to_record(config: FleetConfig) -> list[RecordedTopic]:
    """Every topic robots.yaml names, once each, in config order.

    Raises ConfigError when two settings give one topic two different types (one bag topic has one type).
    """
    wanted: list[RecordedTopic] = []
    for robot in config.robots:
        wanted.append(RecordedTopic(robot.pose.topic, rosmsg.POSE_TYPES[robot.pose.source]))
        if robot.pose.source == "tf":
            wanted.append(RecordedTopic(robot.pose.topic + "_static", rosmsg.POSE_TYPES["tf"], latched=True))
        twist = "geometry_msgs/msg/TwistStamped" if robot.cmd_vel_stamped else "geometry_msgs/msg/Twist"
        wanted.append(RecordedTopic(robot.cmd_vel_topic, twist))
        wanted.append(RecordedTopic(robot.goal_topic, "geometry_msgs/msg/PoseStamped"))
        wanted += [RecordedTopic(s.topic, s.type) for s in robot.sensors]
        if robot.scan_topic is not None:
            wanted.append(RecordedTopic(robot.scan_topic, rosmsg.SCAN_TYPE))
        wanted += [RecordedTopic(c.topic, rosmsg.image_type(c.compressed), image=True) for c in robot.cameras]
    wanted.append(RecordedTopic(config.ros.map_topic, rosmsg.MAP_TYPE, latched=True))
    result: dict[str, RecordedTopic] = {}
    for item in wanted:
        known = result.setdefault(item.topic, item)
        if known.msgtype != item.msgtype:
            raise ConfigError(
                config.source, None, "", f"{item.topic} is named both as {known.msgtype} and as {item.msgtype}"
            )
    return list(result.values())


def _message_class(msgtype: str) -> Any:
    """The rclpy message class of ``pkg/msg/Type``; ImportError or AttributeError when not installed."""
    package, _, name = msgtype.rpartition("/")
    return getattr(importlib.import_module(package.replace("/", ".")), name)


def _offered_qos(node: Any, topic: str) -> list[Any]:
    """The QoS profiles the topic's publishers offer, as rosbags records them in the bag's metadata."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    def duration(value: Any) -> Any:
        sec, nsec = divmod(int(value.nanoseconds), 1_000_000_000)
        return QosTime(sec=sec, nsec=nsec)

    def policy(enum: Any, value: Any) -> Any:
        try:
            return enum(int(value))
        except ValueError:
            return enum.UNKNOWN

    profiles = []
    for info in node.get_publishers_info_by_topic(topic):
        p = info.qos_profile
        profiles.append(
            Qos(
                history=policy(QosHistory, p.history),
                depth=int(p.depth),
                reliability=policy(QosReliability, p.reliability),
                durability=policy(QosDurability, p.durability),
                deadline=duration(p.deadline),
                lifespan=duration(p.lifespan),
                liveliness=policy(QosLiveliness, p.liveliness),
                liveliness_lease_duration=duration(p.liveliness_lease_duration),
                avoid_ros_namespace_conventions=bool(p.avoid_ros_namespace_conventions),
            )
        )
    return profiles


class Recorder:
    """Raw subscriptions to the fleet's topics, written to one MCAP bag. Runs on the calling thread.

    ``record`` owns the bag: it is opened there and closed there, whatever stops the recording.
    """

    def __init__(self, config: FleetConfig, out: Path) -> None:
        self.config = config
        self.out = out
        self.counts: dict[str, int] = {}
        self._stop = threading.Event()

    def stop(self) -> None:
        """Ask ``record`` to finish (safe from a signal handler or another thread)."""
        self._stop.set()

    def record(self, rclpy: Any, duration: float | None) -> float:
        """Record until :meth:`stop` or ``duration`` seconds; returns the seconds recorded."""
        from rosbags.rosbag2 import StoragePlugin, Writer

        qos = importlib.import_module("rclpy.qos")
        executors = importlib.import_module("rclpy.executors")
        signals = importlib.import_module("rclpy.signals")
        context_mod = importlib.import_module("rclpy.context")
        store = typestore()
        context = context_mod.Context()
        # The recorder handles SIGINT and SIGTERM itself, so that the bag is always closed.
        rclpy.init(context=context, signal_handler_options=signals.SignalHandlerOptions.NO)
        node = rclpy.create_node("xr_relay_recorder", context=context)
        executor = executors.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        writer = Writer(self.out, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        writer.open()
        started = time.monotonic()
        try:
            for item in topics_to_record(self.config):
                self._subscribe(node, qos, writer, store, item)
            deadline = started + duration if duration is not None else None
            while not self._stop.is_set() and (deadline is None or time.monotonic() < deadline):
                timeout = 0.1 if deadline is None else max(0.0, min(0.1, deadline - time.monotonic()))
                executor.spin_once(timeout_sec=timeout)
            return time.monotonic() - started
        finally:
            # The bag first: whatever happens to ROS now, the recording is readable.
            writer.close()
            executor.shutdown(timeout_sec=1.0)
            node.destroy_node()
            if context.ok():
                rclpy.shutdown(context=context)

    def _subscribe(self, node: Any, qos: Any, writer: Any, store: Any, item: RecordedTopic) -> None:
        try:
            cls = _message_class(item.msgtype)
        except (ImportError, AttributeError):
            hint = " (not in the PyPI ROS wheels: source a ROS 2 installation)" if "tf2_msgs" in item.msgtype else ""
            logger.warning("%s is not recorded: its type %s is not installed%s", item.topic, item.msgtype, hint)
            return
        if item.msgtype not in store.fielddefs:
            logger.warning("%s is not recorded: rosbags has no definition of %s", item.topic, item.msgtype)
            return
        if item.latched:
            profile = qos.QoSProfile(
                depth=1,
                reliability=qos.ReliabilityPolicy.RELIABLE,
                durability=qos.DurabilityPolicy.TRANSIENT_LOCAL,
            )
        else:
            profile = qos.QoSProfile(
                depth=IMAGE_DEPTH if item.image else DEPTH, reliability=qos.ReliabilityPolicy.BEST_EFFORT
            )
        self.counts[item.topic] = 0
        node.create_subscription(cls, item.topic, self._writer_of(node, writer, store, item), profile, raw=True)

    def _writer_of(self, node: Any, writer: Any, store: Any, item: RecordedTopic) -> Callable[[bytes], None]:
        connection: Any = None

        def write(data: bytes) -> None:
            nonlocal connection
            if connection is None:
                # Declared at the first message, when the publishers (and the QoS they offer) are known.
                offered = _offered_qos(node, item.topic)
                connection = writer.add_connection(
                    item.topic, item.msgtype, typestore=store, offered_qos_profiles=offered
                )
                logger.info("recording %s (%s) from %d publisher(s)", item.topic, item.msgtype, len(offered))
            writer.write(connection, node.get_clock().now().nanoseconds, data)
            self.counts[item.topic] += 1

        return write


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="xr-relay record",
        description="Record the topics of robots.yaml from a live ROS 2 graph into a rosbag2 MCAP bag, which "
        "`xr-relay --backend bag --bag DIR`, `ros2 bag play DIR` and Foxglove replay.",
    )
    parser.add_argument("--out", type=Path, required=True, help="the bag directory to create (must not exist)")
    parser.add_argument(
        "--config", type=Path, default=Path("robots.yaml"), help="fleet configuration (default: ./robots.yaml)"
    )
    parser.add_argument(
        "--duration", type=float, default=None, metavar="SECONDS", help="stop after this long (default: Ctrl-C)"
    )
    parser.add_argument(
        "--log-level", default="info", choices=("debug", "info", "warning", "error"), help="logging verbosity"
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """``xr-relay record ...``; returns the exit status (2: it could not start, with one line saying why)."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=getattr(logging, args.log_level.upper()), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    log = logging.getLogger("relay.cli.record")
    if args.duration is not None and not args.duration > 0:
        log.error("--duration %s: expected a positive number of seconds", args.duration)
        return EXIT_USAGE
    try:
        config = load_config(args.config)
        topics_to_record(config)
    except ConfigError as exc:
        log.error("%s", exc)
        return EXIT_USAGE
    if args.out.exists():
        log.error("%s already exists; choose a new --out directory", args.out)
        return EXIT_USAGE

    try:
        rclpy = load_rclpy()
    except BackendUnavailable as exc:
        log.error("xr-relay record needs rclpy: %s", exc)
        return EXIT_USAGE
    recorder = Recorder(config, args.out)

    def on_signal(signum: int, frame: FrameType | None) -> None:
        recorder.stop()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    log.info(
        "recording the topics of %s to %s (ROS_DOMAIN_ID %s); Ctrl-C stops",
        args.config,
        args.out,
        os.environ.get("ROS_DOMAIN_ID", "0"),
    )
    elapsed = recorder.record(rclpy, args.duration)
    for topic, count in recorder.counts.items():
        if count:
            log.info("%s: %d messages", topic, count)
    silent = [topic for topic, count in recorder.counts.items() if not count]
    if silent:
        log.info("nothing was published on %s", ", ".join(silent))
    total = sum(recorder.counts.values())
    topics = sum(1 for c in recorder.counts.values() if c)
    print(f"recorded {total} messages on {topics} topics in {elapsed:.1f} s to {args.out}", flush=True)  # noqa: T201
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main())
