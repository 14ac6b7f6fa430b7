"""A simulated fleet on a Zenoh network, as robots under rmw_zenoh would show it: no ROS install needed.

    python tools/fake_fleet_zenoh.py [--config robots.yaml] [--listen tcp/127.0.0.1:7447] [--nav2 ...]
    python tools/fake_fleet.py --zenoh ...          (the same)

It is its own Zenoh router, listening where rmw_zenoh's router does by default (tcp/127.0.0.1:7447), which is
where ``xr-relay --backend zenoh`` looks when neither ``--zenoh-connect`` nor robots.yaml's ``zenoh.connect`` says
otherwise: ``make run ARGS="--backend zenoh"`` beside it shows the demo. For every robot of the config it publishes
what tools/fake_fleet.py publishes over DDS (poses, sensors, laser scans, the map with a cache for late joiners,
camera images while someone subscribes), as CDR built by rosbags on rmw_zenoh's keys with its attachment, and
follows cmd_vel and goal_pose. Robots with ``cmd_vel.watchdog`` have their watchdog here (tools/fake_nav2_zenoh.py,
the rules of relay/watchdog/rules.py; ``--no-watchdog``: an ``xr-relay watchdog`` under rmw_zenoh runs instead):
the only publisher of their cmd_vel, the relay's gate and heartbeat in, so a relay that dies stops its robots here.
``--nav2`` (``--misbehave-after-cancel``) as tools/fake_fleet.py: the robots navigate as Nav2 robots do, status,
feedback, cancel_goal and get_result included (Nav2's types through tools/nav2_types.py). Robots with an ``arm:``
get the simulator's arm (tools/fake_arm.py): JointState out, MoveIt Servo's TwistStamped in.
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import json
import logging
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from relay.backends.zenoh_keys import GID_SIZE, Attachment, decode_attachment, topic_key, topic_selector  # noqa: E402
from relay.config import FleetConfig, Robot, load_config  # noqa: E402
from relay.errors import ConfigError  # noqa: E402
from relay.fleet.geometry import quaternion_to_yaw  # noqa: E402
from relay.ros import control_types  # noqa: E402
from relay.ros.ros_env import typestore  # noqa: E402
from relay.ros.rosmsg import POSE_TYPES, image_type  # noqa: E402
from relay.sim import navigator as nav  # noqa: E402
from relay.sim.arms import JOINT_STATE_RATE  # noqa: E402
from relay.sim.laser import LaserScanner  # noqa: E402
from relay.sim.world import Goal, NoPathError, Outcome, SimWorld  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fake_arm import Arms  # noqa: E402
from fake_nav2 import add_nav2_arguments, nav2_ready  # noqa: E402
from fake_nav2_zenoh import ZenohNav2, ZenohWatchdogs  # noqa: E402
from fake_zenoh_messages import SimMessages  # noqa: E402

logger = logging.getLogger("fake_fleet_zenoh")

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"
JOINTS = "sensor_msgs/msg/JointState"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
SCAN_RATE = 10.0


class FakeZenohFleet:
    def __init__(
        self, zenoh: Any, session: Any, config: FleetConfig, domain: int, *, nav2: bool = False,
        misbehave_after_cancel: bool = False, watchdog: bool = True,
    ) -> None:  # fmt: skip
        self.zenoh, self.session, self.config, self.domain = zenoh, session, config, domain
        self.store = control_types.register(typestore())
        self.messages = SimMessages(self.store)
        self.lock = threading.Lock()  # the world is stepped here and commanded from Zenoh's threads
        self.world = SimWorld(config, self._on_nav)
        self.scanner = LaserScanner(self.world.grid)
        self.running = True
        self._sequence = itertools.count(1)
        self._gid = bytes(range(GID_SIZE))
        self.nav2 = nav2
        self.publishers: dict[str, Any] = {}
        self.arms = Arms(config, config.safety.deadman_timeout)
        for robot in config.robots:
            self._declare(robot)
        watched = [r for r in config.robots if r.watchdog_topic is not None] if watchdog else []
        self.watchdogs = None
        if watched:
            timeout = config.safety.deadman_timeout
            self.watchdogs = ZenohWatchdogs(self, watched, timeout, config.ros.heartbeat_topic)
        self.navigation = None
        if nav2:
            self.navigation = ZenohNav2(self, config.robots, misbehave_after_cancel=misbehave_after_cancel)
        map_key = self.key(config.ros.map_topic, "nav_msgs/msg/OccupancyGrid")
        ext = importlib.import_module("zenoh.ext")
        # Transient local, as rmw_zenoh does it: a publisher cache that a late subscriber's history query reads.
        self.map_pub = ext.declare_advanced_publisher(
            session, map_key, cache=ext.CacheConfig(max_samples=1), publisher_detection=True
        )
        self._publish_map()

    # -- keys and publishing ----------------------------------------------------------------------

    def key(self, topic: str, type_name: str) -> str:
        return topic_key("rmw_zenoh", self.domain, topic, type_name, self.store.hash_rihs01(type_name))

    def selector(self, topic: str) -> str:
        return topic_selector("rmw_zenoh", self.domain, topic)

    def put(self, publisher: Any, message: Any, type_name: str) -> None:
        attachment = Attachment(next(self._sequence), time.time_ns(), self._gid).encode()
        publisher.put(bytes(self.store.serialize_cdr(message, type_name)), attachment=attachment)

    def header(self, frame: str) -> Any:
        return self.messages.header(frame)

    def _declare(self, robot: Robot) -> None:
        name = robot.name
        if robot.pose.source == "tf":
            logger.warning("%s: pose source tf is not simulated; publishing nothing", name)
        else:
            self.publishers[f"{name}/pose"] = self.session.declare_publisher(
                self.key(robot.pose.topic, POSE_TYPES[robot.pose.source])
            )
        for sensor in robot.sensors:
            self.publishers[f"{name}/{sensor.name}"] = self.session.declare_publisher(
                self.key(sensor.topic, sensor.type)
            )
        if robot.scan_topic is not None:
            self.publishers[f"{name}/scan"] = self.session.declare_publisher(
                self.key(robot.scan_topic, "sensor_msgs/msg/LaserScan")
            )
        for camera in robot.cameras:
            self.publishers[f"{name}/camera/{camera.name}"] = self.session.declare_publisher(
                self.key(camera.topic, image_type(camera.compressed))
            )
        if robot.arm is not None and name in self.arms.specs:
            topics = robot.arm.topics
            self.publishers[f"{name}/joints"] = self.session.declare_publisher(self.key(topics.joint_states, JOINTS))
            on_twist = lambda s, r=name: self._on_arm_twist(r, s)  # noqa: E731
            self.session.declare_subscriber(self.selector(topics.delta_twist_cmds), on_twist)
            on_trajectory = lambda s, r=name: self._on_arm_trajectory(r, s)  # noqa: E731
            self.session.declare_subscriber(self.selector(topics.joint_trajectory), on_trajectory)
            # The action's send_goal service; its key's hash is the request's (the relay asks any type and hash).
            service, request = f"{topics.gripper_cmd}/_action/send_goal", control_types.SEND_GOAL_REQUEST
            key = topic_key("rmw_zenoh", self.domain, service, request.removesuffix("_Request"),
                            self.store.hash_rihs01(request))  # fmt: skip
            on_goal = lambda q, r=name, k=key: self._on_gripper_goal(r, k, q)  # noqa: E731
            self.session.declare_queryable(key, on_goal, complete=True)
        # The base follows cmd_vel, which the watchdog (or, without one, the relay) publishes.
        self.session.declare_subscriber(self.selector(robot.cmd_vel_topic), lambda s, r=robot: self._on_cmd_vel(r, s))
        if not self.nav2:
            self.session.declare_subscriber(self.selector(robot.goal_topic), lambda s, r=robot: self._on_goal(r, s))

    # -- commands (Zenoh's threads) ---------------------------------------------------------------

    def _on_nav(self, robot: str, navigating: bool, goal: Goal | None, outcome: Outcome, message: str) -> None:
        logger.info("%s: %s %s", robot, outcome, goal)

    def _on_cmd_vel(self, robot: Robot, sample: Any) -> None:
        stamped = robot.cmd_vel_stamped
        type_name = "geometry_msgs/msg/TwistStamped" if stamped else "geometry_msgs/msg/Twist"
        try:
            message = self.store.deserialize_cdr(sample.payload.to_bytes(), type_name)
        except Exception as exc:  # rosbags raises several kinds on bytes that are not the type
            logger.warning("%s: %s on %s is not a %s: %s", robot.name, sample.key_expr, robot.name, type_name, exc)
            return
        twist = message.twist if stamped else message
        linear, angular = float(twist.linear.x), float(twist.angular.z)
        with self.lock:
            self.world.set_velocity(robot.name, linear, angular)

    def _on_arm_twist(self, robot: str, sample: Any) -> None:
        try:
            message = self.store.deserialize_cdr(sample.payload.to_bytes(), TWIST_STAMPED)
        except Exception as exc:  # rosbags raises several kinds on bytes that are not the type
            logger.warning("%s: an arm twist on %s is not a TwistStamped: %s", robot, sample.key_expr, exc)
            return
        t = message.twist
        linear, angular = (t.linear.x, t.linear.y, t.linear.z), (t.angular.x, t.angular.y, t.angular.z)
        self.arms.twist(robot, message.header.frame_id, linear, angular)

    def _on_arm_trajectory(self, robot: str, sample: Any) -> None:
        try:
            message = self.store.deserialize_cdr(sample.payload.to_bytes(), control_types.JOINT_TRAJECTORY)
        except Exception as exc:  # rosbags raises several kinds on bytes that are not the type
            logger.warning("%s: a trajectory on %s is not a JointTrajectory: %s", robot, sample.key_expr, exc)
            return
        if message.points:
            positions = tuple(float(v) for v in message.points[-1].positions)
            self.arms.trajectory(robot, tuple(message.joint_names), positions)

    def _on_gripper_goal(self, robot: str, key: str, query: Any) -> None:
        try:
            position = control_types.read_gripper_goal(query.payload.to_bytes(), self.store.deserialize_cdr)
            request = decode_attachment(query.attachment.to_bytes())
        except Exception as exc:  # no payload or attachment, or not the type
            query.reply_err(f"not a GripperCommand goal: {exc}"[:200].encode())
            query.drop()
            return
        accepted = self.arms.gripper(robot, position)
        # rmw_zenoh's service reply: the request's sequence number and client GID, the reply's own time.
        attachment = Attachment(request.sequence, time.time_ns(), request.gid).encode()
        query.reply(key, control_types.accepted_response(self.store, accepted), attachment=attachment)
        query.drop()

    def _on_goal(self, robot: Robot, sample: Any) -> None:
        try:
            message = self.store.deserialize_cdr(sample.payload.to_bytes(), "geometry_msgs/msg/PoseStamped")
        except Exception as exc:
            logger.warning("%s: a goal on %s is not a PoseStamped: %s", robot.name, sample.key_expr, exc)
            return
        p, q = message.pose.position, message.pose.orientation
        with self.lock:
            try:
                path = self.world.plan(robot.name, float(p.x), float(p.y))
            except NoPathError as exc:
                logger.warning("%s: goal refused: %s", robot.name, exc)
                return
            self.world.follow(robot.name, path, quaternion_to_yaw(q.x, q.y, q.z, q.w))

    # -- the simulation (main thread) -------------------------------------------------------------

    def run(self) -> None:
        sim = self.config.sim
        dt = 1.0 / max(sim.physics_rate, 50.0)
        periods = {"pose": 1.0 / sim.pose_rate, "sensor": 1.0 / sim.sensor_rate, "scan": 1.0 / SCAN_RATE}
        periods["joint"] = 1.0 / JOINT_STATE_RATE
        due = dict.fromkeys(periods, 0.0)
        last = next_nav = time.monotonic()
        self._start_cameras()
        while self.running:
            now = time.monotonic()
            with self.lock:
                self.world.step(min(now - last, 0.2))
            self.arms.step()
            if self.watchdogs is not None:
                self.watchdogs.tick(time.time())
            if self.navigation is not None and now >= next_nav:
                next_nav = max(next_nav + nav.PERIOD, now - nav.PERIOD)
                self.navigation.step(time.time())
            last = now
            for kind, period in periods.items():
                if now >= due[kind]:
                    due[kind] = now + period
                    getattr(self, f"_publish_{kind}s")()
            time.sleep(dt)

    def _publish_poses(self) -> None:
        for robot in self.config.robots:
            publisher = self.publishers.get(f"{robot.name}/pose")
            if publisher is not None:
                message, type_name = self.messages.pose(robot, self.world.robots[robot.name].state)
                self.put(publisher, message, type_name)

    def _publish_sensors(self) -> None:
        for robot in self.config.robots:
            with self.lock:
                readings = self.world.readings(robot.name)
            for sensor_name, value in readings:
                sensor = next(s for s in robot.sensors if s.name == sensor_name)
                message = self.messages.sensor(sensor.type, value, f"{robot.name}/base_link")
                self.put(self.publishers[f"{robot.name}/{sensor_name}"], message, sensor.type)

    def _publish_joints(self) -> None:
        for event in self.arms.states():
            message = self.messages.joint_state(event, f"{event.robot}/base_link")
            self.put(self.publishers[f"{event.robot}/joints"], message, JOINTS)

    def _publish_scans(self) -> None:
        for robot in self.config.robots:
            publisher = self.publishers.get(f"{robot.name}/scan")
            if publisher is None:
                continue
            state = self.world.robots[robot.name].state
            ranges = self.scanner.scan(state.x, state.y, state.yaw).astype(np.float32)
            message = self.messages.scan(self.scanner, ranges, f"{robot.name}/base_scan", SCAN_RATE)
            self.put(publisher, message, "sensor_msgs/msg/LaserScan")

    def _publish_map(self) -> None:
        message = self.messages.map(self.world.grid, self.config.robots[0].pose.map_frame)
        attachment = Attachment(next(self._sequence), time.time_ns(), self._gid).encode()
        self.map_pub.put(bytes(self.store.serialize_cdr(message, "nav_msgs/msg/OccupancyGrid")), attachment=attachment)

    def _start_cameras(self) -> None:
        """Render each camera in a thread of its own, only while a relay subscribes to it (ray casting is dear)."""
        cameras = [(r, c) for r in self.config.robots for c in r.cameras]
        if not cameras or self.world.scene_glb is None:
            return
        from relay.sim.camera import SimCamera
        from relay.twin.frames import map_to_scene_matrix

        m = self.config.scene.map_to_scene
        self.camera = SimCamera.load(self.world.scene_glb, map_to_scene=map_to_scene_matrix(m.x, m.y, m.z, m.yaw))
        for robot, spec in cameras:
            lens = self.camera.fit_lens(spec.lens, spec.width, spec.height)
            args = (
                robot.name,
                spec,
                self.publishers[f"{robot.name}/camera/{spec.name}"],
                lens,
                1.0 / min(spec.rate, 10.0),
            )
            threading.Thread(target=self._camera_loop, args=args, daemon=True).start()

    def _camera_loop(self, robot: str, spec: Any, publisher: Any, lens: Any, period: float) -> None:
        while self.running:
            started = time.monotonic()
            if publisher.matching_status.matching:
                state = self.world.robots[robot].state
                # The spill as grown by now (robots.yaml sim.spill_growth); the world's clock is a float, read whole.
                spill = self.world.spill_at()
                rgb = self.camera.render(float(state.x), float(state.y), float(state.yaw), lens, spill=spill)
                message = self.messages.image(rgb, spec.compressed, f"{robot}/camera_{spec.name}")
                self.put(publisher, message, image_type(spec.compressed))
            time.sleep(max(0.05, period - (time.monotonic() - started)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, default=ROOT / "robots.yaml", help="fleet file (default: robots.yaml)")
    parser.add_argument(
        "--listen", action="append", default=[], metavar="ENDPOINT", help=f"where to listen (default {DEFAULT_LISTEN})"
    )
    parser.add_argument("--domain", type=int, default=0, help="the ROS domain of the keys (default 0)")
    parser.add_argument("--log-level", default="info", choices=("debug", "info", "warning", "error"))
    add_nav2_arguments(parser)
    parser.add_argument("--no-watchdog", action="store_true", help="run no watchdog here (`xr-relay watchdog` does)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        config = load_config(args.config)
        if args.nav2:
            nav2_ready(config)
    except ConfigError as exc:
        logger.error("%s", exc)
        return 2
    try:
        import zenoh
    except ImportError:
        logger.error("fake_fleet_zenoh needs the Zenoh Python API: `pip install '.[zenoh]'`")
        return 2
    listen = args.listen or [DEFAULT_LISTEN]
    zconfig = zenoh.Config()
    zconfig.insert_json5("mode", '"router"')
    zconfig.insert_json5("listen/endpoints", json.dumps(listen))
    zconfig.insert_json5("scouting/multicast/enabled", "false")
    try:
        session: Any = zenoh.open(zconfig)
    except zenoh.ZError as exc:
        logger.error("cannot listen on %s: %s", ", ".join(listen), exc)
        return 2
    fleet = FakeZenohFleet(
        zenoh, session, config, args.domain, nav2=args.nav2, misbehave_after_cancel=args.misbehave_after_cancel,
        watchdog=not args.no_watchdog,
    )  # fmt: skip

    def stop(*_: object) -> None:
        fleet.running = False

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    where = ", ".join(listen)
    print(f"fake_fleet_zenoh: {len(config.robots)} robots, a Zenoh router on {where}", flush=True)  # noqa: T201
    try:
        fleet.run()
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
