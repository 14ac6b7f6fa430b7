"""Backends connect the relay to robots: ``sim`` (built in), ``ros`` (rclpy), ``bag`` (recordings) and ``zenoh``
(ROS 2 over Zenoh, no ROS install); and ``replay``, a recorded station session (``xr-relay replay FILE``,
relay/replay/backend.py), which is not a choice of ``--backend``.

``create_backend`` imports the chosen one lazily, so that ROS is only needed when it is used.
"""

from __future__ import annotations

from ..cli.options import Options
from ..config import FleetConfig
from ..errors import BackendUnavailable
from ..fleet.events import EventSink
from .base import Backend

BACKENDS = ("sim", "ros", "bag", "zenoh")


def create_backend(config: FleetConfig, sink: EventSink, options: Options) -> Backend:
    name = options.backend
    if name == "sim":
        from .sim import SimBackend

        return SimBackend(config, sink)
    if name == "ros":
        from .ros import RosBackend

        return RosBackend(config, sink)
    if name == "bag":
        from .bag import BagBackend

        return BagBackend(config, sink, options.bag)
    if name == "zenoh":
        from .zenoh import ZenohBackend

        return ZenohBackend(config, sink, options.zenoh)
    if name == "replay":
        from ..replay.backend import ReplayBackend

        return ReplayBackend(config, sink, options.replay)
    raise BackendUnavailable(f"unknown backend {name!r}; expected one of {', '.join(BACKENDS)}")
