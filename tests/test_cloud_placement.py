"""A cloud placed in the map at its stamp (relay/cloud/placement.py), and the bounds of the backends' cloud intake
(relay/backends/cloud_intake.py): a rate cap per source, one waiting per source, every failure counted. No I/O."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import pytest

from relay.backends.cloud_intake import CloudIntake
from relay.cloud.errors import CloudError
from relay.cloud.placement import HOLD, Placement, matrix, rpy_matrix
from relay.cloud.pointcloud2 import encode_pointcloud2
from relay.config import parse_config
from relay.fleet.events import CloudEvent, PoseEvent
from tests.helpers.cloud_messages import OPTICAL, pointcloud2, tf_static


def yaw_pose(x: float, yaw: float) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    return (x, 0.0, 0.0), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def test_the_pose_between_two_is_interpolated_and_held_only_briefly() -> None:
    placement = Placement("map", "base_link")
    placement.poses.add(10.0, *yaw_pose(0.0, 0.0))
    placement.poses.add(11.0, *yaw_pose(2.0, math.pi / 2))
    middle = placement.sensor("base_link", 10.5)
    assert np.allclose(middle[:3, 3], [1.0, 0.0, 0.0])
    assert np.allclose(middle[:3, :3], matrix(*yaw_pose(0.0, math.pi / 4))[:3, :3])
    assert np.allclose(placement.sensor("base_link", 11.0 + HOLD)[:3, 3], [2.0, 0.0, 0.0])
    with pytest.raises(CloudError, match=r"no transform at the cloud's stamp 11\.600: .* from 10\.000 to 11\.000"):
        placement.sensor("base_link", 11.6)
    assert np.array_equal(placement.sensor("/map", 99.0), np.eye(4))  # already in the map frame


def test_a_bag_seeked_back_starts_the_history_again() -> None:
    placement = Placement("map", "base_link")
    placement.poses.add(10.0, *yaw_pose(0.0, 0.0))
    placement.poses.add(3.0, *yaw_pose(5.0, 0.0))
    assert np.allclose(placement.sensor("base_link", 3.0)[:3, 3], [5.0, 0.0, 0.0])
    with pytest.raises(CloudError, match="no transform"):
        placement.sensor("base_link", 10.0)


def test_a_sensor_frame_is_linked_to_the_base_through_static_transforms() -> None:
    placement = Placement("map", "base_footprint")
    placement.poses.add(1.0, *yaw_pose(1.0, 0.0))
    lifted = np.eye(4)
    lifted[2, 3] = 0.2
    placement.statics.add("base_footprint", "base_link", lifted)
    placement.statics.add("/base_link", "camera_optical", OPTICAL)
    expected = matrix(*yaw_pose(1.0, 0.0)) @ lifted @ OPTICAL
    assert np.allclose(placement.sensor("camera_optical", 1.0), expected)
    with pytest.raises(CloudError, match="no transform from frame 'lidar' to the robot's base frame 'base_footprint'"):
        placement.sensor("lidar", 1.0)
    # robots.yaml's mount wins over TF; the optical frame as URDF's rpy.
    mount = rpy_matrix(0.1, 0.0, 0.5, -math.pi / 2, 0.0, -math.pi / 2)
    assert np.allclose(mount, OPTICAL)
    assert np.allclose(placement.sensor("lidar", 1.0, mount), matrix(*yaw_pose(1.0, 0.0)) @ OPTICAL)


FLEET = """
cloud:
robots:
  - name: r1
    limits: {linear: 1, angular: 1}
    pose: {source: odom, base_frame: base_link}
    clouds:
      - {name: a, pointcloud2: a, rate: 10}
      - {name: b, pointcloud2: b, rate: 1}
"""


def test_a_source_over_its_rate_is_not_read_and_a_newer_cloud_replaces_the_waiting_one() -> None:
    emitted: list[CloudEvent] = []
    done = threading.Event()

    def emit(event: CloudEvent) -> None:
        emitted.append(event)
        done.set()

    intake = CloudIntake(parse_config(FLEET).robots, emit)
    intake.pose(PoseEvent("r1", 5.0, "map", 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    static = tf_static(0.0, "base_link", "optical", OPTICAL)
    intake.transforms("r1", static)
    points = np.array([[0.0, 0.0, 1.0]], np.float32)
    for k in range(3):  # the thread is not started: they wait, each replacing the one before
        intake.offer("r1", "a", pointcloud2(encode_pointcloud2(points * (k + 1)), 5.0, "optical"), now=k * 0.5)
    intake.offer("r1", "b", pointcloud2(encode_pointcloud2(points), 5.0, "base_link"), now=0.0)
    intake.offer("r1", "b", pointcloud2(encode_pointcloud2(points), 5.0, "base_link"), now=0.1)  # over 1 Hz: not read
    intake.start()
    try:
        for _ in range(200):
            if len(emitted) == 2:
                break
            done.wait(0.05)
    finally:
        intake.stop()
    health = intake.health()["clouds"]
    assert isinstance(health, dict)
    assert (health["r1/a"]["received"], health["r1/a"]["replaced"], health["r1/a"]["decoded"]) == (3, 2, 1)
    assert (health["r1/b"]["received"], health["r1/b"]["capped"], health["r1/b"]["decoded"]) == (2, 1, 1)
    # The newest of a's three, 3 m along the optical axis: 3 m ahead of the robot at (1, 2).
    a = next(e for e in emitted if e.points[0, 2] != 1.0)
    placed = a.pose @ np.append(a.points[0].astype(np.float64), 1.0)
    assert np.allclose(placed[:3], [1.0 + 0.1 + 3.0, 2.0, 0.5])


def counts(intake: CloudIntake) -> dict[str, Any]:
    health = intake.health()["clouds"]
    assert isinstance(health, dict)
    return health


def test_bytes_that_are_not_the_message_and_a_depth_image_without_camera_info_are_named(
    caplog: pytest.LogCaptureFixture,
) -> None:
    from relay.backends.ingest import RawDecoder
    from tests.helpers.cloud_messages import STORE, depth_image

    fleet = FLEET.replace("{name: b, pointcloud2: b, rate: 1}", "{name: d, depth: d/image_raw}")
    intake = CloudIntake(parse_config(fleet).robots, lambda event: None, RawDecoder())
    intake.pose(PoseEvent("r1", 5.0, "map", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    intake.offer("r1", "a", b"\x00\x01\x00\x00garbage")
    image = depth_image(np.ones((4, 4), np.uint16), 5.0, "base_link")
    intake.offer("r1", "d", bytes(STORE.serialize_cdr(image, "sensor_msgs/msg/Image")))
    intake.start()
    try:
        for _ in range(200):
            health = counts(intake)
            if health["r1/a"]["failed"] and health["r1/d"]["failed"]:
                break
            threading.Event().wait(0.05)
    finally:
        intake.stop()
    assert "undecodable sensor_msgs/msg/PointCloud2 (11 bytes)" in health["r1/a"]["last_error"]
    assert health["r1/d"]["last_error"] == "no CameraInfo on /r1/d/camera_info yet"
    assert any("r1 cloud d on /r1/d/image_raw not used: no CameraInfo" in r.getMessage() for r in caplog.records)


def test_a_cloud_newer_than_every_pose_waits_for_the_pose_of_its_instant() -> None:
    emitted: list[CloudEvent] = []
    intake = CloudIntake(parse_config(FLEET).robots, emitted.append)
    intake.pose(PoseEvent("r1", 5.0, "map", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    points = np.array([[1.0, 0.0, 0.0]], np.float32)
    intake.offer("r1", "a", pointcloud2(encode_pointcloud2(points), 6.0, "base_link"))  # 1 s past the newest pose
    intake.start()
    try:
        for _ in range(4):  # it waits, decoded, for a pose (a few of the thread's looks)
            threading.Event().wait(0.05)
        assert not emitted and counts(intake)["r1/a"]["failed"] == 0
        intake.pose(PoseEvent("r1", 6.5, "map", 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
        for _ in range(200):
            if emitted:
                break
            threading.Event().wait(0.05)
    finally:
        intake.stop()
    assert len(emitted) == 1 and np.allclose(emitted[0].pose[:3, 3], [4 / 3, 0.0, 0.0])  # 2/3 of 5.0 to 6.5
