"""The messages the relay sends (Twist, TwistStamped, PoseStamped, the watchdog's Header, an arm's JointTrajectory
and GripperCommand goal) as CDR bytes, built with rosbags' typestore: a backend that publishes bytes (``zenoh``) needs
no ROS install. No I/O.
"""

from __future__ import annotations

from typing import Any

from ..arm.named import JointGoal
from ..fleet.geometry import yaw_to_quaternion
from ..ros.control_types import gripper_goal, joint_trajectory

TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
HEADER = "std_msgs/msg/Header"


class CommandEncoder:
    def __init__(self, store: Any) -> None:
        self._store = store
        self._t = store.types

    def type_hash(self, type_name: str) -> str:
        """The type's RIHS01 hash (REP 2016), as rmw_zenoh puts it in keys."""
        return str(self._store.hash_rihs01(type_name))

    def _header(self, stamp: float, frame: str) -> Any:
        sec = int(stamp)
        time = self._t["builtin_interfaces/msg/Time"](sec=sec, nanosec=int((stamp - sec) * 1e9))
        return self._t[HEADER](stamp=time, frame_id=frame)

    def header(self, stamp: float, frame: str) -> bytes:
        return bytes(self._store.serialize_cdr(self._header(stamp, frame), HEADER))

    def twist(self, linear: float, angular: float, *, stamped: bool, stamp: float, frame: str) -> bytes:
        vector = self._t["geometry_msgs/msg/Vector3"]
        twist = self._t[TWIST](
            linear=vector(x=float(linear), y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=float(angular))
        )
        if not stamped:
            return bytes(self._store.serialize_cdr(twist, TWIST))
        message = self._t[TWIST_STAMPED](header=self._header(stamp, frame), twist=twist)
        return bytes(self._store.serialize_cdr(message, TWIST_STAMPED))

    def arm_twist(
        self, linear: tuple[float, float, float], angular: tuple[float, float, float], *, stamp: float, frame: str
    ) -> bytes:
        """MoveIt Servo's input: a TwistStamped of the arm's tip, in ``frame`` (the arm's base link)."""
        vector = self._t["geometry_msgs/msg/Vector3"]
        twist = self._t[TWIST](linear=vector(*map(float, linear)), angular=vector(*map(float, angular)))
        message = self._t[TWIST_STAMPED](header=self._header(stamp, frame), twist=twist)
        return bytes(self._store.serialize_cdr(message, TWIST_STAMPED))

    def joint_goal(self, goal: JointGoal) -> bytes:
        """An arm controller's input for a named pose: a one-point trajectory_msgs/JointTrajectory."""
        return joint_trajectory(self._store, goal.names, goal.positions, goal.seconds)

    def gripper(self, position: float) -> bytes:
        """A gripper controller's GripperCommand goal (its action's SendGoal request), under a new goal id."""
        return gripper_goal(self._store, position)

    def goal(self, x: float, y: float, yaw: float | None, *, stamp: float, frame: str) -> bytes:
        # Nav2 needs a valid quaternion; without a requested yaw, keep the identity (facing +x).
        qx, qy, qz, qw = yaw_to_quaternion(yaw if yaw is not None else 0.0)
        pose = self._t["geometry_msgs/msg/Pose"](
            position=self._t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
            orientation=self._t["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
        )
        message = self._t[POSE_STAMPED](header=self._header(stamp, frame), pose=pose)
        return bytes(self._store.serialize_cdr(message, POSE_STAMPED))
