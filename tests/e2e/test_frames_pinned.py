"""relay/twin/frames.py against the same pinned points as the client's xr_client/src/frames.js
(xr_client/test/fixtures/frames_points.json is the one table both sides check)."""

from __future__ import annotations

import json

import numpy as np

from relay.twin import frames
from tests.conftest import ROOT

POINTS = json.loads((ROOT / "xr_client" / "test" / "fixtures" / "frames_points.json").read_text())


def test_ros_to_gltf_pinned_points() -> None:
    for case in POINTS["ros_to_gltf"]:
        assert np.allclose(frames.ros_to_gltf(*case["ros"]), case["gltf"])
        assert np.allclose(frames.gltf_to_ros(*case["gltf"]), case["ros"])
        homogeneous = frames.ROS_TO_GLTF @ np.array([*case["ros"], 1.0])
        assert np.allclose(homogeneous[:3], case["gltf"])


def test_map_to_scene_pinned_points() -> None:
    for case in POINTS["map_to_scene"]:
        t = case["transform"]
        matrix = frames.map_to_scene_matrix(t["x"], t["y"], t["z"], t["yaw"])
        scene_ros = matrix @ np.array([*case["map"], 1.0])
        assert np.allclose(frames.ros_to_gltf(*scene_ros[:3]), case["gltf"])
