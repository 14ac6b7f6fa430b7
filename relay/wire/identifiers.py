"""Identifiers and coalescing keys: built here, never by f-strings elsewhere.

Robot-scoped identifiers are ``<robot>/<kind>``; global ones are their own kind (``hello``, ``playback/pause``).
"""

from __future__ import annotations

import re
from typing import Final

ROBOT_NAME_PATTERN: Final = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,63}$")

#: Robot-scoped kinds the server sends.
SERVER_ROBOT_KINDS: Final = ("pose", "sensor", "status", "scan", "nav", "path", "lease", "model", "joints")
#: Global identifiers the server sends.
SERVER_GLOBAL_KINDS: Final = (
    "hello", "ack", "error", "pong", "estop", "scene", "playback", "backend", "targets", "targets_changed", "mission",
    "finding", "findings", "region", "operators", "alert", "schedules", "voxel_map", "study", "avatar", "valve",
)  # fmt: skip


def robot_identifier(robot: str, kind: str) -> str:
    """``<robot>/<kind>``: the identifier of a robot-scoped message (``robot1/pose``)."""
    return f"{robot}/{kind}"


def camera_identifier(robot: str, camera: str) -> str:
    """The identifier of a camera's binary frames and of its stream lane (``robot1/camera/front``)."""
    return f"{robot}/camera/{camera}"


def split_camera_identifier(identifier: str) -> tuple[str, str]:
    """``robot1/camera/front`` -> ``("robot1", "front")``; the inverse of :func:`camera_identifier`."""
    robot, sep, camera = identifier.partition("/camera/")
    if not sep or not robot or not camera:
        raise ValueError(f"not a camera identifier: {identifier!r}")
    return robot, camera


def sensor_key(robot: str, name: str) -> str:
    """The coalescing key of one sensor's readings: each sensor keeps its own newest value."""
    return f"{robot}/sensor/{name}"
