"""robots.yaml's ``cloud`` section (issue #33): defaults, and errors that name the field."""

from __future__ import annotations

import pytest

from relay.config import Cloud, CloudSource, Mount, parse_config
from relay.errors import ConfigError

ROBOTS = "robots: [{name: r1, limits: {linear: 1, angular: 1}}]\n"


def test_absent_means_no_map_and_empty_means_defaults() -> None:
    assert parse_config(ROBOTS).cloud is None
    assert parse_config(ROBOTS + "cloud:\n").cloud == Cloud()
    assert parse_config(ROBOTS + "cloud: {voxel: 0.1, budget_blocks: 500, save_every: 5, sim_depth_rate: 0}\n").cloud \
        == Cloud(0.1, 500, 5.0, 0.0)  # fmt: skip


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("cloud: {voxel: 2}", "robots.yaml:2: cloud.voxel: expected a voxel side of 0.01 to 1 m, got 2"),
        ("cloud: {voxel: -1}", "cloud.voxel: expected a positive number, got -1"),
        ("cloud: {budget_blocks: 0}", "cloud.budget_blocks: expected a positive integer, got 0"),
        ("cloud: {save_every: never}", 'cloud.save_every: expected a positive number, got "never"'),
        ("cloud: {sim_depth_rate: 50}", "cloud.sim_depth_rate: expected at most 10 Hz, got 50"),
        ("cloud: {voxels: 0.1}", "voxels"),
    ],
)
def test_errors_name_the_field(text: str, message: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config(ROBOTS + text + "\n")
    assert message in str(caught.value)


ROBOT = "robots:\n  - name: r1\n    limits: {linear: 1, angular: 1}\n    clouds:\n"


def test_a_robots_clouds_take_their_topics_in_its_namespace() -> None:
    config = parse_config(
        ROBOT
        + "      - {name: lidar, pointcloud2: velodyne_points, rate: 5, mount: {z: 0.4, yaw: 0.5}}\n"
        + "      - {name: kinect, depth: camera/depth/image_raw, stride: 2}\n"
        + "      - {name: other, depth: /cam/depth, camera_info: /cam/info}\n"
    )
    lidar, kinect, other = config.robots[0].clouds
    assert lidar == CloudSource("lidar", "pointcloud2", "/r1/velodyne_points", None, Mount(z=0.4, yaw=0.5), 5.0, 1)
    assert kinect == CloudSource("kinect", "depth", "/r1/camera/depth/image_raw", "/r1/camera/depth/camera_info",
                                 None, 2.0, 2)  # fmt: skip
    assert (other.topic, other.camera_info) == ("/cam/depth", "/cam/info")
    assert parse_config(ROBOTS).robots[0].clouds == ()


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ("{name: a}", "robots.yaml:5: robots[0].clouds[0].pointcloud2: expected exactly one of pointcloud2 or depth"),
        ("{name: a, pointcloud2: p, depth: d}", "robots[0].clouds[0].pointcloud2: expected exactly one of"),
        ("{name: a, pointcloud2: 'no topic'}", "robots[0].clouds[0].pointcloud2: expected a ROS topic name"),
        ("{name: a, pointcloud2: p, camera_info: i}", "robots[0].clouds[0].camera_info: only a depth image has"),
        ("{name: a, pointcloud2: p, rate: 50}", "robots[0].clouds[0].rate: expected at most 10 Hz, got 50"),
        ("{name: a, pointcloud2: p, rate: 0}", "robots[0].clouds[0].rate: expected a positive number, got 0"),
        ("{name: a, depth: d, stride: 40}", "robots[0].clouds[0].stride: expected 1 to 16, got 40"),
        ("{name: a, pointcloud2: p, mount: {z: up}}", 'robots[0].clouds[0].mount.z: expected a number, got "up"'),
        ("{name: a, pointcloud2: p, mount: {w: 1}}", "robots[0].clouds[0].mount.w: unknown field"),
        ("{name: a, pointcloud2: p, colour: red}", "robots[0].clouds[0].colour: unknown field"),
    ],
)
def test_a_bad_cloud_source_names_the_file_line_and_field(entry: str, message: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config(ROBOT + f"      - {entry}\n")
    assert message in str(caught.value)


def test_two_clouds_may_not_share_a_name_or_a_topic() -> None:
    with pytest.raises(ConfigError, match=r"robots.yaml:6: robots\[0\].clouds\[1\].name: duplicate cloud name"):
        parse_config(ROBOT + "      - {name: a, pointcloud2: p}\n      - {name: a, pointcloud2: q}\n")
    with pytest.raises(ConfigError, match=r"clouds\[1\].depth: topic /r1/p is already cloud \"a\""):
        parse_config(ROBOT + "      - {name: a, pointcloud2: p}\n      - {name: b, depth: p}\n")
