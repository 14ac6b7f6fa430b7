"""The hand-written Odometry decode the bare raw subscribers use: the relay's own (relay/ros/cdr.py)."""

from relay.ros.cdr import odometry_pose, odometry_stamp, verify

__all__ = ["odometry_pose", "odometry_stamp", "verify"]
