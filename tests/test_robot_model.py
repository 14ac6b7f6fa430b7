"""Robot models: URDF (files and a bag's /robot_description) -> GLB, the fallbacks, and scenes/robot.glb.

Reads the TurtleBot3 description and the walker bag from ../shared/data; the tests that need them skip with
the missing path when the folder is absent. GLBs are checked with the Khronos validator
(tests/gltf_validate.py) and by decoding them here: node names, world-space bounds converted back to ROS
axes, materials.
"""

from __future__ import annotations

import importlib.util
import json
import logging
import math
import struct
import xml.etree.ElementTree as ET
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
import trimesh
from numpy.typing import NDArray

import relay.twin.urdf as urdf_module
from relay.twin.frames import GLTF_TO_ROS
from relay.twin.urdf import (
    BODY_MATERIAL,
    ROOT_NODE,
    TYRE_MATERIAL,
    RobotModelError,
    procedural_robot_glb,
    robot_description_glb,
    substitute_namespace,
    urdf_to_glb,
)
from tests.conftest import SHARED_DATA
from tests.gltf_validate import issues_text, unavailable_reason, validate_glb

ROOT = Path(__file__).resolve().parents[1]
SHARED = SHARED_DATA
TB3 = SHARED / "robot" / "turtlebot3_description"
BAG = SHARED / "bags" / "tb3_walker_syzygy21" / "walker_data_2024_11_23_15_54_49"
MAX_BYTES = 3_000_000


# ------------------------------------------------------------------------------------------------ helpers


def _need(path: Path) -> Path:
    if not path.exists():
        pytest.skip(f"shared data not found at {path}")
    return path


def _urdf(name: str) -> str:
    return (_need(TB3) / "urdf" / f"{name}.urdf").read_text(encoding="utf-8")


def _tool(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"_tool_{name}", ROOT / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _assert_valid(glb: bytes) -> None:
    reason = unavailable_reason()
    if reason is not None:
        pytest.skip(reason)
    report = validate_glb(glb)
    assert report["issues"]["numErrors"] == 0, issues_text(report)
    assert report["issues"]["numWarnings"] == 0, issues_text(report)


class Glb:
    """A decoded GLB: its JSON, its binary chunk, and world transforms of named nodes."""

    def __init__(self, data: bytes) -> None:
        magic, version, length = struct.unpack_from("<4sII", data, 0)
        assert (magic, version, length) == (b"glTF", 2, len(data))
        json_length, json_type = struct.unpack_from("<II", data, 12)
        assert json_type == 0x4E4F534A
        self.doc: dict[str, Any] = json.loads(data[20 : 20 + json_length])
        offset = 20 + json_length
        self.binary = b""
        if offset < len(data):
            bin_length, bin_type = struct.unpack_from("<II", data, offset)
            assert bin_type == 0x004E4942
            self.binary = data[offset + 8 : offset + 8 + bin_length]
        self.world: dict[str, NDArray[np.float64]] = {}
        self.index: dict[str, int] = {}
        roots = self.doc["scenes"][self.doc["scene"]]["nodes"]
        for root in roots:
            self._walk(root, np.eye(4))

    def _walk(self, index: int, parent: NDArray[np.float64]) -> None:
        node = self.doc["nodes"][index]
        matrix = parent @ _local(node)
        assert node["name"] not in self.world, f"node name {node['name']} twice"
        self.world[node["name"]] = matrix
        self.index[node["name"]] = index
        for child in node.get("children", []):
            self._walk(child, matrix)

    @property
    def names(self) -> set[str]:
        return set(self.world)

    def node(self, name: str) -> dict[str, Any]:
        node: dict[str, Any] = self.doc["nodes"][self.index[name]]
        return node

    def positions(self, accessor_index: int) -> NDArray[np.float64]:
        accessor = self.doc["accessors"][accessor_index]
        view = self.doc["bufferViews"][accessor["bufferView"]]
        count = accessor["count"]
        start = view["byteOffset"] + accessor.get("byteOffset", 0)
        return np.frombuffer(self.binary, "<f4", count * 3, start).reshape(-1, 3).astype(np.float64)

    def triangle_count(self, name: str) -> int:
        mesh = self.doc["meshes"][self.node(name)["mesh"]]
        return sum(self.doc["accessors"][p["indices"]]["count"] // 3 for p in mesh["primitives"])

    def materials_of(self, name: str) -> list[str]:
        mesh = self.doc["meshes"][self.node(name)["mesh"]]
        return [self.doc["materials"][p["material"]]["name"] for p in mesh["primitives"]]

    def world_points(self, names: set[str] | None = None) -> NDArray[np.float64]:
        """Every vertex of the named nodes' meshes (all nodes when None), in world glTF coordinates."""
        chunks = []
        for name, matrix in self.world.items():
            node = self.node(name)
            if "mesh" not in node or (names is not None and name not in names):
                continue
            for primitive in self.doc["meshes"][node["mesh"]]["primitives"]:
                local = self.positions(primitive["attributes"]["POSITION"])
                chunks.append(local @ matrix[:3, :3].T + matrix[:3, 3])
        return np.concatenate(chunks)

    def ros_bounds(self, names: set[str] | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        points = self.world_points(names) @ GLTF_TO_ROS[:3, :3].T
        return points.min(axis=0), points.max(axis=0)


def _local(node: dict[str, Any]) -> NDArray[np.float64]:
    assert "matrix" not in node
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    assert math.isclose(x * x + y * y + z * z + w * w, 1.0, abs_tol=1e-6)
    matrix = np.eye(4)
    matrix[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    matrix[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return matrix


def _link_names(urdf_text: str) -> set[str]:
    return {link.attrib["name"] for link in ET.fromstring(urdf_text).findall("link")}


@pytest.fixture(scope="module")
def waffle_pi() -> tuple[bytes, list[str]]:
    return urdf_to_glb(_urdf("turtlebot3_waffle_pi"), [_need(TB3)])


# ------------------------------------------------------------------------------------------ TurtleBot3


def test_waffle_pi_is_valid_small_deterministic_and_complete(waffle_pi: tuple[bytes, list[str]]) -> None:
    glb, warnings = waffle_pi
    assert warnings == []
    _assert_valid(glb)
    assert len(glb) < MAX_BYTES
    assert urdf_to_glb(_urdf("turtlebot3_waffle_pi"), [TB3]) == (glb, warnings), "output is not deterministic"

    model = Glb(glb)
    links = _link_names(substitute_namespace(_urdf("turtlebot3_waffle_pi")))
    assert model.names == links | {ROOT_NODE}
    root = model.doc["nodes"][0]
    assert model.doc["scenes"][0]["nodes"] == [0]
    assert root["name"] == ROOT_NODE and "translation" not in root and "rotation" not in root
    assert [model.doc["nodes"][i]["name"] for i in root["children"]] == ["base_footprint"]
    # The Waffle Pi's mesh files hold 121 k triangles; the model keeps at most MODEL_TRIANGLE_BUDGET (50 k) of them,
    # most in the body, and draws the same from 40 cm (relay/twin/urdf/__init__.py says why).
    meshes = [n["name"] for n in model.doc["nodes"] if "mesh" in n]
    total = sum(model.triangle_count(name) for name in meshes)
    assert 0.8 * urdf_module.MODEL_TRIANGLE_BUDGET < total <= urdf_module.MODEL_TRIANGLE_BUDGET + 2_000, total
    assert model.triangle_count("base_link") > total / 3
    assert model.materials_of("base_link") == [BODY_MATERIAL]
    assert model.materials_of("wheel_left_link") == [TYRE_MATERIAL]
    assert model.materials_of("wheel_right_link") == [TYRE_MATERIAL]
    # URDF colour "dark" (sRGB 0.3) becomes linear 0.0732 in glTF.
    (lidar,) = model.materials_of("base_scan")
    factor = next(m for m in model.doc["materials"] if m["name"] == lidar)["pbrMetallicRoughness"]["baseColorFactor"]
    assert lidar == "dark" and factor == pytest.approx([0.0732, 0.0732, 0.0732, 1.0], abs=1e-4)
    body = next(m for m in model.doc["materials"] if m["name"] == BODY_MATERIAL)
    assert body["pbrMetallicRoughness"]["baseColorFactor"][:3] == [0.7, 0.7, 0.7]


def test_waffle_pi_has_turtlebot_dimensions_in_metres_and_y_up(waffle_pi: tuple[bytes, list[str]]) -> None:
    model = Glb(waffle_pi[0])
    lo, hi = model.ros_bounds()
    size = hi - lo
    # TurtleBot3 Waffle Pi: 281 x 306 x 141 mm (the shared base mesh is the simplified 266 mm one).
    assert 0.25 < size[0] < 0.30, size
    assert 0.29 < size[1] < 0.32, size
    assert 0.10 < size[2] < 0.25, size
    assert lo[2] == pytest.approx(0.0, abs=0.002), "the wheels stand on the ground plane"
    assert -lo[1] == pytest.approx(hi[1], abs=0.002), "left and right wheels mirror each other"

    # Height is glTF +y: the lidar (ROS z = 0.010 + 0.122) sits at glTF y = 0.132, and ROS -y is glTF +z.
    scan = model.world["base_scan"][:3, 3]
    assert scan == pytest.approx([-0.064, 0.132, 0.0], abs=1e-9)
    left_wheel = model.world["wheel_left_link"][:3, 3]
    assert left_wheel == pytest.approx([0.0, 0.033, -0.144], abs=1e-9)
    gltf_points = model.world_points()
    assert np.ptp(gltf_points[:, 1]) == pytest.approx(size[2], abs=1e-6)
    assert gltf_points[:, 1].min() == pytest.approx(0.0, abs=0.002)
    # The wheel's mesh lies around its joint frame, so turning that node about its axis spins the wheel.
    wheel_lo, wheel_hi = model.ros_bounds({"wheel_left_link"})
    assert (wheel_lo + wheel_hi) / 2 == pytest.approx([0.0, 0.144, 0.033], abs=0.002)
    assert wheel_hi - wheel_lo == pytest.approx([0.066, 0.018, 0.066], abs=0.002)


def test_burger_converts_with_its_own_dimensions() -> None:
    glb, warnings = urdf_to_glb(_urdf("turtlebot3_burger"), [_need(TB3)])
    assert warnings == []
    _assert_valid(glb)
    assert len(glb) < MAX_BYTES
    model = Glb(glb)
    assert model.names == _link_names(substitute_namespace(_urdf("turtlebot3_burger"))) | {ROOT_NODE}
    lo, hi = model.ros_bounds()
    # TurtleBot3 Burger: 138 x 178 x 192 mm.
    assert (hi - lo) == pytest.approx([0.138, 0.178, 0.192], abs=0.006)


def test_waffle_collada_units_and_missing_base_mesh() -> None:
    """The Waffle's r200.dae is in inches (<unit meter="0.00254">) and its waffle_base.stl is missing."""
    glb, warnings = urdf_to_glb(_urdf("turtlebot3_waffle"), [_need(TB3)])
    _assert_valid(glb)
    assert len(warnings) == 1 and "waffle_base.stl" in warnings[0] and "box" in warnings[0], warnings
    model = Glb(glb)
    # The stand-in is base_link's collision box: 0.266 x 0.266 x 0.094 centred 0.064 m behind the link.
    lo, hi = model.ros_bounds({"base_link"})
    assert hi - lo == pytest.approx([0.266, 0.266, 0.094], abs=1e-6)
    assert (lo + hi) / 2 == pytest.approx([-0.064, 0.0, 0.057], abs=1e-6)
    # The RealSense R200 is 130 mm wide: metres after the COLLADA unit, not 51 inches-as-metres.
    cam_lo, cam_hi = model.ros_bounds({"camera_link"})
    assert cam_hi[1] - cam_lo[1] == pytest.approx(0.130, abs=0.003)


def test_namespace_placeholders_are_substituted_or_stripped() -> None:
    text = _urdf("turtlebot3_burger")
    assert "${namespace}" in text
    glb, _ = urdf_to_glb(text, [_need(TB3)], namespace="tb3_0/")
    names = Glb(glb).names
    assert {"tb3_0/base_footprint", "tb3_0/base_link", "tb3_0/wheel_left_link"} <= names
    assert not any("$" in name for name in names)
    assert Glb(glb).doc["nodes"][0]["extras"]["reference_link"] == "tb3_0/base_footprint"
    assert substitute_namespace("<link name='${ namespace }a'/>") == "<link name='a'/>"


def test_robot_description_from_the_bag_converts_like_the_file(waffle_pi: tuple[bytes, list[str]]) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    # The bag stores no message definitions: std_msgs/String comes from the default Humble typestore.
    with AnyReader([_need(BAG)], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        connections = [c for c in reader.connections if c.topic == "/robot_description"]
        assert connections, "the bag has no /robot_description"
        texts: list[str] = []
        for connection, _, raw in reader.messages(connections=connections):
            message: Any = reader.deserialize(raw, connection.msgtype)
            texts.append(message.data)
    assert len(texts) == 1 and "<robot" in texts[0]

    glb, warnings = urdf_to_glb(texts[0], [TB3])
    _assert_valid(glb)
    assert Glb(glb).names == Glb(waffle_pi[0]).names
    # Its meshes live in turtlebot3_gazebo, which the shared data does not have: every one falls back to
    # the link's collision geometry, with a warning naming the file.
    for missing in ("waffle_pi_base.dae", "tire.dae", "lds.dae"):
        assert any(missing in w and "collision geometry" in w for w in warnings), (missing, warnings)
    assert len(warnings) == 4
    lo, hi = Glb(glb).ros_bounds()
    assert hi - lo == pytest.approx([0.266, 0.306, 0.1413], abs=0.002)

    # The relay's entry point gives the same model and logs the warnings instead of returning them.
    assert robot_description_glb(texts[0], [TB3]) == glb


# ------------------------------------------------------------------------------------------- fallbacks

_MISSING_MESH_URDF = """<?xml version="1.0"?>
<robot name="r">
  <link name="base_footprint"/>
  <joint name="j0" type="fixed"><parent link="base_footprint"/><child link="base_link"/></joint>
  <link name="base_link">
    <visual><geometry><mesh filename="package://nowhere_pkg/meshes/chassis.stl" scale="0.001 0.001 0.001"/>
    </geometry></visual>
    <collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.2" length="0.1"/></geometry></collision>
  </link>
  <joint name="j1" type="fixed"><parent link="base_link"/><child link="sensor_link"/>
    <origin xyz="0.1 0 0.2"/></joint>
  <link name="sensor_link">
    <visual><origin xyz="0 0 0.01"/><geometry><mesh filename="file:///no/such/dir/sensor.dae"/></geometry></visual>
  </link>
</robot>
"""


def test_a_missing_mesh_gives_the_collision_shape_or_a_box_and_a_warning(tmp_path: Path) -> None:
    glb, warnings = urdf_to_glb(_MISSING_MESH_URDF, [tmp_path])
    _assert_valid(glb)
    assert len(warnings) == 2, warnings
    assert "package://nowhere_pkg/meshes/chassis.stl" in warnings[0] and "cylinder" in warnings[0]
    assert "sensor.dae" in warnings[1] and "5 cm box" in warnings[1]
    model = Glb(glb)
    lo, hi = model.ros_bounds({"base_link"})
    assert hi - lo == pytest.approx([0.4, 0.4, 0.1], abs=1e-6)
    assert (lo + hi) / 2 == pytest.approx([0.0, 0.0, 0.05], abs=1e-6)
    lo, hi = model.ros_bounds({"sensor_link"})
    assert hi - lo == pytest.approx([0.05, 0.05, 0.05], abs=1e-6)
    assert (lo + hi) / 2 == pytest.approx([0.1, 0.0, 0.21], abs=1e-6)

    with pytest.raises(RobotModelError, match=r"chassis\.stl"):
        urdf_to_glb(_MISSING_MESH_URDF, [tmp_path], fallback=False)

    # A file that is there but is no mesh is treated the same way.
    (tmp_path / "broken.stl").write_bytes(b"this is not a mesh")
    broken = (
        '<robot name="r"><link name="a"><visual><geometry><mesh filename="broken.stl"/></geometry></visual>'
        "</link></robot>"
    )
    glb, warnings = urdf_to_glb(broken, [tmp_path])
    assert len(warnings) == 1 and "broken.stl" in warnings[0] and "box" in warnings[0], warnings


def test_mesh_uris_resolve_only_where_allowed(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """package:// and file:// resolve; package:// cannot climb out of its package, and the relay's entry
    point reads nothing outside its search paths."""
    package = tmp_path / "src" / "my_robot"
    (package / "meshes").mkdir(parents=True)
    (package / "package.xml").write_text("<package><name>my_robot_description</name></package>")
    trimesh.creation.box(extents=(100.0, 200.0, 300.0)).export(package / "meshes" / "body.stl")
    outside = tmp_path / "outside.stl"
    trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(outside)

    def urdf(uri: str) -> str:
        return (
            '<robot name="r"><link name="base_link"><visual><geometry>'
            f'<mesh filename="{uri}" scale="0.001 0.001 0.001"/></geometry></visual></link></robot>'
        )

    by_manifest = urdf("package://my_robot_description/meshes/body.stl")
    for paths in ([package], [package.parent], {"my_robot_description": package}):
        glb, warnings = urdf_to_glb(by_manifest, paths)
        assert warnings == [], paths
        lo, hi = Glb(glb).ros_bounds()
        assert hi - lo == pytest.approx([0.1, 0.2, 0.3], abs=1e-6)
    _assert_valid(glb)

    climbing = urdf("package://my_robot_description/../../outside.stl")
    _, warnings = urdf_to_glb(climbing, [package])
    assert len(warnings) == 1 and "outside.stl not found" in warnings[0]

    absolute = urdf(outside.as_uri())
    _, warnings = urdf_to_glb(absolute, [package])
    assert warnings == []
    caplog.set_level(logging.WARNING, logger="relay.twin.urdf")
    confined = robot_description_glb(absolute, [package])
    lo, hi = Glb(confined).ros_bounds()
    assert hi - lo == pytest.approx([0.05, 0.05, 0.05], abs=1e-6), "the outside file must not be read"
    assert any("outside.stl" in r.getMessage() for r in caplog.records)


def test_unusable_descriptions_raise_or_fall_back_to_the_procedural_model(caplog: pytest.LogCaptureFixture) -> None:
    for text in ("", "<robot name='r'>", "<not_a_robot/>", "<robot name='r'/>"):
        with pytest.raises(RobotModelError):
            urdf_to_glb(text, [])
    broken_tree = (
        "<robot name='r'><link name='a'/><joint name='j' type='fixed'>"
        "<parent link='a'/><child link='ghost'/></joint></robot>"
    )
    with pytest.raises(RobotModelError, match="ghost"):
        urdf_to_glb(broken_tree, [])
    loop = (
        "<robot name='r'><link name='a'/><link name='b'/>"
        "<joint name='j1' type='fixed'><parent link='a'/><child link='b'/></joint>"
        "<joint name='j2' type='fixed'><parent link='b'/><child link='a'/></joint></robot>"
    )
    with pytest.raises(RobotModelError, match="loop"):
        urdf_to_glb(loop, [])
    with pytest.raises(RobotModelError, match="loop"):
        urdf_to_glb(loop.replace("<link name='a'/>", "<link name='root'/><link name='a'/>"), [])
    caplog.set_level(logging.WARNING, logger="relay.twin.urdf")
    assert robot_description_glb("not xml at all", []) == procedural_robot_glb()
    assert any("procedural" in r.getMessage() for r in caplog.records)


def test_a_second_root_is_kept_once_with_a_warning() -> None:
    text = (
        "<robot name='r'><link name='base_link'/><link name='dock'/><link name='dock_light'>"
        "<visual><geometry><sphere radius='0.1'/></geometry></visual></link>"
        "<joint name='j' type='fixed'><parent link='dock'/><child link='dock_light'/>"
        "<origin xyz='1 0 0'/></joint></robot>"
    )
    glb, warnings = urdf_to_glb(text, [])
    _assert_valid(glb)
    assert warnings == ["link dock is not connected to base_link by joints; placed at its origin"]
    model = Glb(glb)  # Glb fails on a node name seen twice
    assert model.names == {ROOT_NODE, "base_link", "dock", "dock_light"}
    assert model.world["dock_light"][:3, 3] == pytest.approx([1.0, 0.0, 0.0])


def test_huge_meshes_are_simplified_to_the_budget(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=100.0)  # 20 480 triangles, millimetres
    sphere.export(tmp_path / "ball.stl")
    text = (
        '<robot name="r"><link name="base_link"><visual><geometry>'
        '<mesh filename="ball.stl" scale="0.001 0.001 0.001"/></geometry></visual></link></robot>'
    )
    monkeypatch.setattr(urdf_module, "MODEL_TRIANGLE_BUDGET", 4000)
    glb, warnings = urdf_to_glb(text, [tmp_path])
    assert warnings == []
    _assert_valid(glb)
    model = Glb(glb)
    assert 1000 < model.triangle_count("base_link") <= 4000
    lo, hi = model.ros_bounds()
    assert hi - lo == pytest.approx([0.2, 0.2, 0.2], abs=0.004), "simplification keeps the shape's size"
    radii = np.linalg.norm(model.world_points(), axis=1)
    assert radii == pytest.approx(np.full_like(radii, 0.1), abs=0.003), "vertices stay on the sphere"
    assert urdf_to_glb(text, [tmp_path])[0] == glb


# ----------------------------------------------------------------------------------- procedural model


def test_procedural_model_is_valid_turtlebot_sized_with_a_forward_nose() -> None:
    glb = procedural_robot_glb()
    _assert_valid(glb)
    assert procedural_robot_glb() == glb
    model = Glb(glb)
    assert {ROOT_NODE, "base_footprint", "base_link", "wheel_left_link", "wheel_right_link", "camera_link"} <= (
        model.names
    )
    assert model.materials_of("base_link") == [BODY_MATERIAL]
    lo, hi = model.ros_bounds({"base_link"})
    assert hi[:2] - lo[:2] == pytest.approx([0.30, 0.30], abs=0.01)
    lo, hi = model.ros_bounds()
    assert hi[0] > -lo[0] + 0.03, "the nose must stick out ahead (+x ROS) further than the back does"
    assert lo[2] == pytest.approx(0.0, abs=1e-6)
    camera = model.world["camera_link"][:3, 3] @ GLTF_TO_ROS[:3, :3].T
    assert camera[2] > 0.25, "the camera head sits on a mast"


# -------------------------------------------------------------------------------------------- the tool


def test_committed_robot_glb_is_a_fresh_build(waffle_pi: tuple[bytes, list[str]]) -> None:
    _need(TB3)
    fresh, warnings, source = _tool("build_robot").build()
    assert source.endswith("turtlebot3_waffle_pi.urdf") and warnings == []
    assert fresh == waffle_pi[0]
    committed = ROOT / "scenes" / "robot.glb"
    assert committed.is_file(), f"{committed} is missing: run python tools/build_robot.py"
    assert committed.read_bytes() == fresh, f"{committed} is stale: run python tools/build_robot.py"


def test_tool_writes_the_procedural_model_without_shared_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    tool = _tool("build_robot")
    monkeypatch.setattr(tool, "DEFAULT_URDF", tmp_path / "absent" / "robot.urdf")
    out = tmp_path / "robot.glb"
    assert tool.main(["--out", str(out)]) == 0
    assert out.read_bytes() == procedural_robot_glb()
    assert "procedural" in capsys.readouterr().out
