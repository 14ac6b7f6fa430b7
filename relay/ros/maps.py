"""nav_msgs/OccupancyGrid messages (from rclpy or from a bag: the fields are the same) to map events.

Shared by the ``ros`` and ``bag`` backends; pure numpy, called on their own threads, never on the loop.
"""

from __future__ import annotations

import logging
from typing import Any

from ..fleet.events import MapEvent
from ..fleet.geometry import quaternion_to_yaw
from ..twin.map_twin import ros_map_layers

logger = logging.getLogger(__name__)


def map_event(message: Any, stamp: float, source: str) -> MapEvent:
    """The MapEvent of one OccupancyGrid; raises ValueError when its data does not fit its size."""
    info = message.info
    q = info.origin.orientation
    if abs(quaternion_to_yaw(q.x, q.y, q.z, q.w)) > 1e-3:
        logger.warning("%s: the map's origin is rotated; its bounds and twin use the unrotated extent", source)
    grid, unknown = ros_map_layers(
        message.data,
        int(info.width),
        int(info.height),
        float(info.resolution),
        float(info.origin.position.x),
        float(info.origin.position.y),
    )
    return MapEvent(grid, stamp, unknown=unknown)
