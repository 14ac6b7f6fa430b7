"""Pure pieces the ros and bag backends share: TF composition, image conversion, the simulated laser."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from relay.fleet.geometry import quaternion_to_yaw, yaw_to_quaternion
from relay.media.imaging import ImageError, compressed_to_jpeg, encode_jpeg, jpeg_size, raw_to_bgr
from relay.ros.tf import TfPose, Transform, compose
from relay.sim.floorplan import demo_facility, rasterise
from relay.sim.laser import LaserScanner


def planar(x: float, y: float, yaw: float) -> Transform:
    return Transform((x, y, 0.0), yaw_to_quaternion(yaw))


def test_compose_planar_transforms() -> None:
    # map->odom: odom sits at (1, 2) turned 90 degrees; the robot is 1 m ahead in odom.
    result = compose(planar(1.0, 2.0, math.pi / 2), planar(1.0, 0.0, 0.25))
    assert result.translation == pytest.approx((1.0, 3.0, 0.0))
    assert quaternion_to_yaw(*result.rotation) == pytest.approx(math.pi / 2 + 0.25)


def test_tf_pose_uses_map_once_localised() -> None:
    tf = TfPose("map", "odom", "base_footprint")
    assert tf.pose() is None
    assert not tf.feed("odom", "wheel_left", planar(0, 0, 0))
    assert tf.feed("/odom", "base_footprint", planar(2.0, 0.0, 0.0))
    frame, pose = tf.pose() or ("", planar(0, 0, 0))
    assert frame == "odom" and pose.translation[0] == pytest.approx(2.0)
    assert tf.feed("map", "odom", planar(-1.0, 0.5, 0.0))
    frame, pose = tf.pose() or ("", planar(0, 0, 0))
    assert frame == "map" and pose.translation[:2] == pytest.approx((1.0, 0.5))


def image(width: int = 64, height: int = 48) -> np.ndarray:
    rng = np.random.default_rng(1)
    return rng.integers(0, 255, (height, width, 3), dtype=np.uint8)


@pytest.mark.parametrize("encoding", ["rgb8", "bgr8", "rgba8", "bgra8"])
def test_raw_colour_encodings_become_bgr(encoding: str) -> None:
    bgr = image()
    source = {
        "rgb8": cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB),
        "bgr8": bgr,
        "rgba8": cv2.cvtColor(bgr, cv2.COLOR_BGR2RGBA),
        "bgra8": cv2.cvtColor(bgr, cv2.COLOR_BGR2BGRA),
    }[encoding]
    # A row stride with padding, as drivers often send.
    step = source.shape[1] * source.shape[2] + 8
    padded = np.zeros((source.shape[0], step), np.uint8)
    padded[:, : source.shape[1] * source.shape[2]] = source.reshape(source.shape[0], -1)
    assert np.array_equal(raw_to_bgr(padded.tobytes(), 64, 48, encoding, step), bgr)


def test_mono_and_16bit_images() -> None:
    grey = np.arange(48 * 64, dtype=np.uint8).reshape(48, 64)
    assert np.array_equal(raw_to_bgr(grey.tobytes(), 64, 48, "mono8", 64), grey)
    depth = np.full((48, 64), 1000, np.uint16)
    depth[0, 0] = 4000
    out = raw_to_bgr(depth.tobytes(), 64, 48, "16UC1", 128)
    assert out.dtype == np.uint8 and out[0, 0] == 255 and out[1, 1] == 63
    with pytest.raises(ImageError, match="yuv422"):
        raw_to_bgr(b"\0" * 100, 10, 5, "yuv422", 20)
    with pytest.raises(ImageError, match="does not hold"):
        raw_to_bgr(b"\0" * 100, 64, 48, "rgb8", 192)


def test_jpeg_size_and_passthrough() -> None:
    jpeg = encode_jpeg(image(640, 480))
    assert jpeg_size(jpeg) == (640, 480)
    assert jpeg_size(b"\x89PNG....") is None
    data, width, height = compressed_to_jpeg(jpeg, "rgb8; jpeg compressed bgr8")
    assert data is jpeg and (width, height) == (640, 480)
    png = cv2.imencode(".png", image(32, 16))[1].tobytes()
    data, width, height = compressed_to_jpeg(png, "png")
    assert data[:2] == b"\xff\xd8" and (width, height) == (32, 16)
    with pytest.raises(ImageError, match="could not be decoded"):
        compressed_to_jpeg(b"garbage", "png")


def test_simulated_laser_sees_the_walls() -> None:
    scanner = LaserScanner(rasterise(demo_facility()))
    # robot1's spawn: the corridor's south wall 1.5 m behind... the outer wall (y in [0, 0.2]).
    ranges = scanner.scan(3.0, 1.5, math.pi / 2)
    assert len(ranges) == 360
    behind = ranges[0]  # angle_min = -pi: straight behind a robot facing north
    assert behind == pytest.approx(1.5 - 0.2, abs=0.06)
    # Straight ahead is the door at x = 3 and the chemical storage room beyond: a long free beam.
    ahead = ranges[180]
    assert ahead > 5.0


def test_odometry_cdr_decode_matches_rclpy() -> None:
    """relay/ros/cdr.py reads the pose of raw Odometry bytes exactly as rclpy deserialises it, for every
    alignment of the two frame-id strings."""
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'`")
    import random

    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message

    from relay.ros.cdr import odometry_pose

    rng = random.Random(3)
    for i in range(40):
        message = Odometry()
        message.header.stamp.sec = rng.randint(0, 2**31 - 1)
        message.header.stamp.nanosec = rng.randint(0, 999_999_999)
        message.header.frame_id = "odom"[: i % 5] + "x" * (i % 7)
        message.child_frame_id = "base" * (i % 3)
        p, q = message.pose.pose.position, message.pose.pose.orientation
        p.x, p.y, p.z = (rng.uniform(-1e3, 1e3) for _ in range(3))
        q.x, q.y, q.z, q.w = (rng.uniform(-1, 1) for _ in range(4))
        decoded = odometry_pose(serialize_message(message))
        assert (decoded.x, decoded.y, decoded.z, decoded.qx, decoded.qy, decoded.qz, decoded.qw) == (
            p.x, p.y, p.z, q.x, q.y, q.z, q.w,
        )  # fmt: skip
        assert decoded.frame == message.header.frame_id
        assert decoded.stamp == pytest.approx(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9, abs=1e-9)
    with pytest.raises(ValueError):
        odometry_pose(b"\x00\x09" + bytes(40))
