"""A robot's ``clouds:`` in robots.yaml: the topics of its point clouds and depth images for the live 3D map.

Each entry is one sensor: ``pointcloud2: TOPIC`` (sensor_msgs/PointCloud2) or ``depth: TOPIC`` (sensor_msgs/Image,
16UC1 or 32FC1) with ``camera_info`` (sensor_msgs/CameraInfo; by default the depth topic's sibling
``camera_info``, as image_pipeline names them: ``camera/depth/image_raw`` -> ``camera/depth/camera_info``). Topics
are relative to the robot's namespace unless absolute. ``mount`` places the sensor on the robot's base frame when TF
does not (no /tf_static, or a pose source other than ``tf``); ``rate`` caps how many of its clouds a second are read.
"""

from __future__ import annotations

from yaml.nodes import Node

from ..session.protocol import ROBOT_NAME_PATTERN
from .model import CloudSource, Mount
from .reader import _Reader, _topic

CLOUD_FIELDS = ("name", "pointcloud2", "depth", "camera_info", "mount", "rate", "stride")
MOUNT_FIELDS = ("x", "y", "z", "roll", "pitch", "yaw")
#: Clouds a second one source may bring (a lidar's 10-20 Hz is more than a 300 000-point fusion keeps up with).
MAX_CLOUD_RATE = 10.0
#: A depth image's coarsest sampling: every 16th pixel of a 640x480 image is still 1200 points.
MAX_STRIDE = 16


def clouds(reader: _Reader, node: Node, path: str, namespace: str) -> tuple[CloudSource, ...]:
    """The ``clouds`` list at ``path`` of a robot in ``namespace``: names and topics each used once."""
    sources: list[CloudSource] = []
    for i, item in reader.sequence(node, path):
        where = f"{path}[{i}]"
        source = _source(reader, item, where, namespace)
        for other in sources:
            if other.name == source.name:
                raise reader.fail(item, f"{where}.name", f'duplicate cloud name "{source.name}"')
            if other.topic == source.topic:
                raise reader.fail(
                    item, f"{where}.{source.kind}", f'topic {source.topic} is already cloud "{other.name}"'
                )
        sources.append(source)
    return tuple(sources)


def _source(reader: _Reader, node: Node, path: str, namespace: str) -> CloudSource:
    f = reader.mapping(node, path, CLOUD_FIELDS, required=("name",))
    name = reader.string(f["name"], f"{path}.name", pattern=ROBOT_NAME_PATTERN, expected="a cloud name")
    kinds = [k for k in ("pointcloud2", "depth") if k in f]
    if len(kinds) != 1:
        raise reader.fail(node, f"{path}.pointcloud2", "expected exactly one of pointcloud2 or depth (a topic)")
    kind = kinds[0]
    topic = _topic(reader, f[kind], f"{path}.{kind}", namespace)
    camera_info = None
    if kind == "depth":
        camera_info = topic.rpartition("/")[0] + "/camera_info"
        if "camera_info" in f:
            camera_info = _topic(reader, f["camera_info"], f"{path}.camera_info", namespace)
    elif "camera_info" in f:
        raise reader.fail(f["camera_info"], f"{path}.camera_info", "only a depth image has a camera_info")
    rate = reader.get(f, "rate", path, lambda n, p: reader.number(n, p, positive=True), CloudSource.rate)
    if rate > MAX_CLOUD_RATE:
        raise reader.fail(f["rate"], f"{path}.rate", f"expected at most {MAX_CLOUD_RATE:g} Hz, got {rate:g}")
    stride = reader.get(f, "stride", path, reader.integer, CloudSource.stride)
    if "stride" in f and (kind != "depth" or stride > MAX_STRIDE):
        why = f"expected 1 to {MAX_STRIDE}, got {stride}" if kind == "depth" else "only a depth image has a stride"
        raise reader.fail(f["stride"], f"{path}.stride", why)
    mount = _mount(reader, f["mount"], f"{path}.mount") if "mount" in f else None
    return CloudSource(name, kind, topic, camera_info, mount, rate, stride)


def _mount(reader: _Reader, node: Node, path: str) -> Mount:
    f = reader.mapping(node, path, MOUNT_FIELDS)
    return Mount(*(reader.get(f, key, path, reader.number, 0.0) for key in MOUNT_FIELDS))
