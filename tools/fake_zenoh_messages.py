"""The simulated robots' state as ROS messages in rosbags' types, as tools/fake_fleet_zenoh.py publishes them: poses,
sensor readings, laser scans, the map, camera images and arms' joints, each stamped now."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from relay.config import Robot
from relay.fleet.events import JointStateEvent
from relay.fleet.geometry import yaw_to_quaternion
from relay.fleet.occupancy import OccupancyGrid
from relay.ros.rosmsg import POSE_TYPES
from relay.sim.kinematics import DiffDriveState
from relay.sim.laser import LaserScanner

#: Sensor values as their messages carry them (ratios where ROS uses them: relay.ros.rosmsg reports percent).
_SENSOR_FIELDS = {
    "Float32": ("data", 1.0),
    "Float64": ("data", 1.0),
    "Temperature": ("temperature", 1.0),
    "RelativeHumidity": ("relative_humidity", 0.01),
    "FluidPressure": ("fluid_pressure", 1.0),
    "Illuminance": ("illuminance", 1.0),
    "BatteryState": ("percentage", 0.01),
}


class SimMessages:
    """Builds the messages from rosbags' type store ``store`` (the one the fleet serializes them with)."""

    def __init__(self, store: Any) -> None:
        self.t = store.types

    def header(self, frame: str) -> Any:
        now = time.time()
        stamp = self.t["builtin_interfaces/msg/Time"](sec=int(now), nanosec=int((now - int(now)) * 1e9))
        return self.t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def pose(self, robot: Robot, state: DiffDriveState) -> tuple[Any, str]:
        """The robot's pose as its pose source publishes it (Odometry, PoseWithCovarianceStamped or PoseStamped)."""
        t = self.t
        qx, qy, qz, qw = yaw_to_quaternion(float(state.yaw))
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=float(state.x), y=float(state.y), z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
        )
        source = robot.pose.source
        covariance = np.zeros(36)
        if source == "odom":
            vector = t["geometry_msgs/msg/Vector3"]
            twist = t["geometry_msgs/msg/Twist"](
                linear=vector(x=float(state.linear), y=0.0, z=0.0),
                angular=vector(x=0.0, y=0.0, z=float(state.angular)),
            )
            message = t["nav_msgs/msg/Odometry"](
                header=self.header(robot.pose.odom_frame),
                child_frame_id=robot.pose.base_frame,
                pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=covariance),
                twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=covariance),
            )
        elif source == "amcl_pose":
            message = t["geometry_msgs/msg/PoseWithCovarianceStamped"](
                header=self.header(robot.pose.map_frame),
                pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=covariance),
            )
        else:
            message = t["geometry_msgs/msg/PoseStamped"](header=self.header(robot.pose.map_frame), pose=pose)
        return message, POSE_TYPES[source]

    def sensor(self, type_name: str, value: float, frame: str) -> Any:
        cls = type_name.rsplit("/", 1)[-1]
        fields: dict[str, Any]
        if cls == "Int32":
            fields = {"data": round(value)}
        else:
            field, scale = _SENSOR_FIELDS[cls]
            fields = {field: float(value) * scale}
            if cls not in ("Float32", "Float64"):
                fields = self._full(type_name, {"header": self.header(frame), **fields})
        return self.t[type_name](**fields)

    def joint_state(self, event: JointStateEvent, frame: str) -> Any:
        """An arm's sensor_msgs/JointState, as joint_state_broadcaster publishes it (no efforts)."""
        return self.t["sensor_msgs/msg/JointState"](
            header=self.header(frame),
            name=list(event.names),
            position=np.asarray(event.positions, dtype=np.float64),
            velocity=np.asarray(event.velocities, dtype=np.float64),
            effort=np.zeros(0, dtype=np.float64),
        )

    def _full(self, type_name: str, given: dict[str, Any]) -> dict[str, Any]:
        """Every field of a message type, zero/empty where not ``given`` (BatteryState has many)."""
        out: dict[str, Any] = {}
        for name, field in self.t[type_name].__dataclass_fields__.items():
            if name == "__msgtype__":
                continue
            if name in given:
                out[name] = given[name]
            elif field.type in ("float", "int"):
                out[name] = 0 if field.type == "int" else 0.0
            elif field.type == "bool":
                out[name] = False
            elif field.type == "str":
                out[name] = ""
            else:
                out[name] = np.zeros(0, np.float32) if "ndarray" in str(field.type) else []
        return out

    def scan(self, scanner: LaserScanner, ranges: np.ndarray, frame: str, rate: float) -> Any:
        s = scanner
        return self.t["sensor_msgs/msg/LaserScan"](
            header=self.header(frame), angle_min=s.angle_min,
            angle_max=s.angle_min + s.angle_increment * (len(ranges) - 1), angle_increment=s.angle_increment,
            time_increment=0.0, scan_time=1.0 / rate, range_min=s.range_min, range_max=s.range_max,
            ranges=ranges, intensities=np.zeros(0, np.float32),
        )  # fmt: skip

    def map(self, grid: OccupancyGrid, frame: str) -> Any:
        t = self.t
        origin = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=grid.origin_x, y=grid.origin_y, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        )
        zero = t["builtin_interfaces/msg/Time"](sec=0, nanosec=0)
        info = t["nav_msgs/msg/MapMetaData"](
            map_load_time=zero, resolution=grid.resolution, width=grid.width, height=grid.height, origin=origin
        )
        data = (grid.occupied.astype(np.int8) * 100).ravel()
        return t["nav_msgs/msg/OccupancyGrid"](header=self.header(frame), info=info, data=data)

    def image(self, rgb: np.ndarray, compressed: bool, frame: str) -> Any:
        header = self.header(frame)
        if compressed:
            from relay.sim.camera import rgb_to_jpeg

            return self.t["sensor_msgs/msg/CompressedImage"](
                header=header, format="jpeg", data=np.frombuffer(rgb_to_jpeg(rgb), np.uint8)
            )
        return self.t["sensor_msgs/msg/Image"](
            header=header, height=rgb.shape[0], width=rgb.shape[1], encoding="rgb8", is_bigendian=0,
            step=rgb.shape[1] * 3, data=np.ascontiguousarray(rgb).reshape(-1),
        )  # fmt: skip
