"""A simulated fleet on a real ROS 2 graph: the ``sim`` backend's robots, over DDS.

    python tools/fake_fleet.py [--config robots.yaml] [--nav2 [--misbehave-after-cancel]] [--no-watchdog]
    python tools/fake_fleet.py --zenoh [--listen tcp/127.0.0.1:7447]   (over Zenoh, no ROS: fake_fleet_zenoh.py)

For every robot of the config it publishes its pose (on the robot's pose topic, as Odometry,
PoseWithCovarianceStamped or PoseStamped according to its pose source), its sensors (with the configured
message types), a LaserScan and, when a client asks, camera images (sensor_msgs/Image rgb8 or a JPEG
CompressedImage, once the simulated camera is available), and the facility's map on the map topic
(transient local). It follows ``cmd_vel`` (Twist or TwistStamped) and ``goal_pose`` (PoseStamped) like the
``sim`` backend does; robots with ``cmd_vel.watchdog`` get their teleop through the watchdog (relay/watchdog),
which runs in this process, on the robots' side of the network (``--no-watchdog``: it runs elsewhere, as
``xr-relay watchdog``). It is the demo for people without robots, and the counterpart of the integration tests:
``xr-relay --backend ros`` against it gives the same experience as ``--backend sim``. Robots with an ``arm:`` get a
fake one (tools/fake_arm.py): joint states out, MoveIt Servo's twists in, through the simulator's kinematics.

``--nav2``: each robot navigates as a Nav2 robot does (tools/fake_nav2.py): goal_pose starts a NavigateToPose goal
whose status, cancel service (and, with nav2_msgs, feedback and result) are Nav2's, and whose controller publishes
on ``navigation.autonomy`` (``cmd_vel_nav``) at 20 Hz. The base moves only from ``cmd_vel``, which only the watchdog
publishes: every robot needs ``cmd_vel.watchdog``. ``--misbehave-after-cancel``: the controller keeps publishing
after a cancel, which the watchdog's gate must hold against (docs/reliability.md).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from relay.config import FleetConfig, Robot, load_config  # noqa: E402
from relay.errors import ConfigError, RelayError  # noqa: E402
from relay.fleet.geometry import quaternion_to_yaw, yaw_to_quaternion  # noqa: E402
from relay.sim.laser import LaserScanner  # noqa: E402
from relay.sim.world import Goal, NoPathError, Outcome, SimWorld  # noqa: E402
from relay.watchdog.node import Watchdogs  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fake_arm import FakeArms  # noqa: E402
from fake_nav2 import Nav2Servers, add_nav2_arguments, nav2_ready  # noqa: E402

logger = logging.getLogger("fake_fleet")

SCAN_RATE = 10.0


def sensor_message(classes: dict[str, Any], msg_type: str, value: float, header: Any) -> Any:
    """A message of ``msg_type`` carrying ``value`` (percentages back to ratios where ROS uses them)."""
    name = msg_type.rsplit("/", 1)[-1]
    message = classes[name]()
    if name in ("Float32", "Float64"):
        message.data = float(value)
    elif name == "Int32":
        message.data = round(value)
    else:
        message.header = header
        if name == "Temperature":
            message.temperature = float(value)
        elif name == "RelativeHumidity":
            message.relative_humidity = float(value) / 100.0
        elif name == "FluidPressure":
            message.fluid_pressure = float(value)
        elif name == "Illuminance":
            message.illuminance = float(value)
        elif name == "BatteryState":
            message.percentage = float(value) / 100.0
    return message


class FakeFleet:
    def __init__(
        self, config: FleetConfig, *, nav2: bool = False, misbehave_after_cancel: bool = False, watchdog: bool = True
    ) -> None:
        import rclpy
        from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist, TwistStamped
        from nav_msgs.msg import OccupancyGrid, Odometry
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import (
            BatteryState,
            FluidPressure,
            Illuminance,
            LaserScan,
            RelativeHumidity,
            Temperature,
        )
        from std_msgs.msg import Float32, Float64, Int32

        self.rclpy = rclpy
        self.config = config
        self.classes: dict[str, Any] = {
            "Float32": Float32,
            "Float64": Float64,
            "Int32": Int32,
            "Temperature": Temperature,
            "RelativeHumidity": RelativeHumidity,
            "FluidPressure": FluidPressure,
            "Illuminance": Illuminance,
            "BatteryState": BatteryState,
        }
        self.world = SimWorld(config, self._on_nav)
        self.scanner = LaserScanner(self.world.grid)
        self.node = rclpy.create_node("fake_fleet")
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        self.pose_pubs: dict[str, tuple[Any, Any]] = {}
        self.sensor_pubs: dict[tuple[str, str], Any] = {}
        self.scan_pubs: dict[str, Any] = {}
        self.LaserScan = LaserScan
        for robot in config.robots:
            source = robot.pose.source
            if source == "tf":
                logger.warning("%s: pose source tf is not simulated (no tf2_msgs); publishing nothing", robot.name)
            else:
                cls = {"odom": Odometry, "amcl_pose": PoseWithCovarianceStamped, "pose": PoseStamped}[source]
                self.pose_pubs[robot.name] = (cls, self.node.create_publisher(cls, robot.pose.topic, reliable))
            for sensor in robot.sensors:
                cls = self.classes[sensor.type.rsplit("/", 1)[-1]]
                self.sensor_pubs[(robot.name, sensor.name)] = self.node.create_publisher(cls, sensor.topic, reliable)
            if robot.scan_topic is not None:
                self.scan_pubs[robot.name] = self.node.create_publisher(LaserScan, robot.scan_topic, reliable)
            twist_cls = TwistStamped if robot.cmd_vel_stamped else Twist
            self.node.create_subscription(
                twist_cls, robot.cmd_vel_topic, lambda m, r=robot: self._on_cmd_vel(r, m), reliable
            )
            if not nav2:
                self.node.create_subscription(
                    PoseStamped, robot.goal_topic, lambda m, r=robot: self._on_goal(r, m), reliable
                )
        self.map_pub = self.node.create_publisher(OccupancyGrid, config.ros.map_topic, latched)
        self._publish_map(OccupancyGrid)
        # Robots whose cmd_vel.watchdog is set get the relay's teleop through a watchdog on the robot's side, as
        # real robots should (docs/reliability.md): it stops them when the relay cannot.
        watched = [robot for robot in config.robots if robot.watchdog_topic is not None] if watchdog else []
        self.watchdogs = Watchdogs(self.node, config, watched, config.safety.deadman_timeout) if watched else None
        self.nav2 = None
        if nav2:
            self.nav2 = Nav2Servers(self.node, self.world, config.robots, misbehave_after_cancel=misbehave_after_cancel)
        self.arms = FakeArms(self.node, config, config.safety.deadman_timeout)
        self._cameras: list[tuple[str, Any, Any, Any, float]] = []  # robot, camera spec, publisher, lens, period
        self._start_cameras()
        sim = config.sim
        self.dt = 1.0 / max(sim.physics_rate, 50.0)
        self.node.create_timer(self.dt, self._step)
        self.node.create_timer(1.0 / sim.pose_rate, self._publish_poses)
        self.node.create_timer(1.0 / sim.sensor_rate, self._publish_sensors)
        self.node.create_timer(1.0 / SCAN_RATE, self._publish_scans)
        self._last_step = time.monotonic()

    def _start_cameras(self) -> None:
        """Render each robot's camera in its own thread, only while someone subscribes to it."""
        cameras = [(r, c) for r in self.config.robots for c in r.cameras]
        if not cameras or self.world.scene_glb is None:
            return
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import CompressedImage, Image

        from relay.sim.camera import SimCamera
        from relay.twin.frames import map_to_scene_matrix

        m = self.config.scene.map_to_scene
        self.camera = SimCamera.load(self.world.scene_glb, map_to_scene=map_to_scene_matrix(m.x, m.y, m.z, m.yaw))
        # Reliable, depth 1, as image_transport publishes: the relay's camera subscriptions are reliable.
        images = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
        for robot, spec in cameras:
            cls = CompressedImage if spec.compressed else Image
            publisher = self.node.create_publisher(cls, spec.topic, images)
            lens = self.camera.fit_lens(spec.lens, spec.width, spec.height)
            # Ray casting costs ~0.1 s a frame on two cores: 10 fps is the most a demo fleet can afford.
            period = 1.0 / min(spec.rate, 10.0)
            thread = threading.Thread(
                target=self._camera_loop, args=(robot.name, spec, publisher, lens, period), daemon=True
            )
            thread.start()

    def _camera_loop(self, robot: str, spec: Any, publisher: Any, lens: Any, period: float) -> None:
        from sensor_msgs.msg import CompressedImage, Image

        from relay.sim.camera import rgb_to_jpeg

        while self.rclpy.ok():
            started = time.monotonic()
            if publisher.get_subscription_count() > 0:
                state = self.world.robots[robot].state
                # The spill as grown by now (robots.yaml sim.spill_growth); the world's clock is a float, read whole.
                spill = self.world.spill_at()
                rgb = self.camera.render(float(state.x), float(state.y), float(state.yaw), lens, spill=spill)
                header = self._header(f"{robot}/camera_{spec.name}")
                if spec.compressed:
                    message = CompressedImage(header=header, format="jpeg", data=rgb_to_jpeg(rgb))
                else:
                    message = Image(header=header, height=rgb.shape[0], width=rgb.shape[1], encoding="rgb8")
                    message.step = rgb.shape[1] * 3
                    message.data = rgb.tobytes()
                publisher.publish(message)
            time.sleep(max(0.05, period - (time.monotonic() - started)))

    def _header(self, frame: str) -> Any:
        from std_msgs.msg import Header

        header = Header()
        header.stamp = self.node.get_clock().now().to_msg()
        header.frame_id = frame
        return header

    def _on_nav(self, robot: str, navigating: bool, goal: Goal | None, outcome: Outcome, message: str) -> None:
        logger.info("%s: %s %s", robot, outcome, goal)

    def _on_cmd_vel(self, robot: Robot, message: Any) -> None:
        twist = message.twist if hasattr(message, "twist") else message
        self.world.set_velocity(robot.name, float(twist.linear.x), float(twist.angular.z))

    def _on_goal(self, robot: Robot, message: Any) -> None:
        p, q = message.pose.position, message.pose.orientation
        yaw = quaternion_to_yaw(q.x, q.y, q.z, q.w)
        try:
            path = self.world.plan(robot.name, float(p.x), float(p.y))
        except NoPathError as exc:
            logger.warning("%s: goal refused: %s", robot.name, exc)
            return
        self.world.follow(robot.name, path, yaw)

    def _step(self) -> None:
        # Integrate the time that really passed: timers jitter, and the robots must keep their speed.
        now = time.monotonic()
        elapsed = min(now - self._last_step, 0.2)
        self._last_step = now
        self.world.step(elapsed)

    def _publish_poses(self) -> None:
        for name, (cls, publisher) in self.pose_pubs.items():
            state = self.world.robots[name].state
            spec = self.world.robots[name].spec
            message = cls()
            frame = spec.pose.odom_frame if spec.pose.source == "odom" else spec.pose.map_frame
            message.header = self._header(frame)
            pose = message.pose.pose if hasattr(message.pose, "pose") else message.pose
            pose.position.x, pose.position.y = state.x, state.y
            qx, qy, qz, qw = yaw_to_quaternion(state.yaw)
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = qx, qy, qz, qw
            if hasattr(message, "child_frame_id"):
                message.child_frame_id = spec.pose.base_frame
                message.twist.twist.linear.x = state.linear
                message.twist.twist.angular.z = state.angular
            publisher.publish(message)

    def _publish_sensors(self) -> None:
        for name, sim in self.world.robots.items():
            for sensor_name, value in self.world.readings(name):
                sensor = next(s for s in sim.spec.sensors if s.name == sensor_name)
                header = self._header(f"{name}/base_link")
                self.sensor_pubs[(name, sensor_name)].publish(sensor_message(self.classes, sensor.type, value, header))

    def _publish_scans(self) -> None:
        for name, publisher in self.scan_pubs.items():
            state = self.world.robots[name].state
            ranges = self.scanner.scan(state.x, state.y, state.yaw)
            message = self.LaserScan()
            message.header = self._header(f"{name}/base_scan")
            message.angle_min = self.scanner.angle_min
            message.angle_max = self.scanner.angle_min + self.scanner.angle_increment * (len(ranges) - 1)
            message.angle_increment = self.scanner.angle_increment
            message.range_min = self.scanner.range_min
            message.range_max = self.scanner.range_max
            message.scan_time = 1.0 / SCAN_RATE
            message.ranges = ranges.tolist()
            publisher.publish(message)

    def _publish_map(self, cls: Any) -> None:
        grid = self.world.grid
        message = cls()
        message.header = self._header(self.config.robots[0].pose.map_frame)
        message.info.resolution = grid.resolution
        message.info.width, message.info.height = grid.width, grid.height
        message.info.origin.position.x, message.info.origin.position.y = grid.origin_x, grid.origin_y
        message.info.origin.orientation.w = 1.0
        message.data = (grid.occupied.astype("int8") * 100).ravel().tolist()
        self.map_pub.publish(message)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "--zenoh" in argv:
        # The same fleet as robots under rmw_zenoh would show it, its own Zenoh router (no ROS install needed).
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        sibling = importlib.import_module("fake_fleet_zenoh")
        return int(sibling.main([a for a in argv if a != "--zenoh"]))
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, default=ROOT / "robots.yaml", help="fleet file (default: robots.yaml)")
    parser.add_argument("--log-level", default="info", choices=("debug", "info", "warning", "error"))
    parser.add_argument("--zenoh", action="store_true", help="over Zenoh instead of DDS (tools/fake_fleet_zenoh.py)")
    add_nav2_arguments(parser)
    parser.add_argument(
        "--no-watchdog", action="store_true", help="run no watchdog here: `xr-relay watchdog` runs beside the fleet"
    )
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
        import rclpy
        from rclpy.executors import ExternalShutdownException
    except ImportError:
        logger.error("fake_fleet needs rclpy: `pip install '.[ros]'` or source a ROS 2 installation")
        return 2
    rclpy.init()
    try:
        fleet = FakeFleet(
            config, nav2=args.nav2, misbehave_after_cancel=args.misbehave_after_cancel, watchdog=not args.no_watchdog
        )
    except RelayError as exc:  # a required arm whose URDF cannot be read
        logger.error("%s", exc)
        rclpy.try_shutdown()
        return 2
    signal.signal(signal.SIGTERM, lambda *_: rclpy.try_shutdown())
    arms = f" ({len(fleet.arms)} with an arm)" if len(fleet.arms) else ""
    print(f"fake_fleet: {len(config.robots)} robots{arms} on ROS_DOMAIN_ID", end=" ", flush=True)  # noqa: T201
    import os

    print(os.environ.get("ROS_DOMAIN_ID", "0"), flush=True)  # noqa: T201
    try:
        rclpy.spin(fleet.node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if fleet.watchdogs is not None:
            fleet.watchdogs.stop_all()
        fleet.node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
