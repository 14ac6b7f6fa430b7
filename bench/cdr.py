"""The hand-written Odometry decode the bare raw subscribers use: the relay's own (relay/cdr.py)."""

from relay.cdr import OdometryPose, odometry_pose, odometry_stamp, verify

__all__ = ["OdometryPose", "odometry_pose", "odometry_stamp", "verify"]
