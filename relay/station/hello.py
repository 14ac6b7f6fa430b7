"""The ``hello`` a client gets first: who it is, the scene, the rooms, every robot and its state, the backend."""

from __future__ import annotations

from collections.abc import Sequence

from .. import SERVER_NAME, __version__
from ..backends.base import Backend
from ..config import Robot
from ..fleet.occupancy import OccupancyGrid
from ..fleet.vantage import Vantage
from ..session.protocol import PROTOCOL_VERSION, Role
from .assets import GeneratedAssets
from .description import describe_robot
from .messages import HelloMessage, PlaybackMessage, RobotState, RoomDescription, backend_message


def hello_message(
    client_id: str,
    role: Role,
    *,
    grid: OccupancyGrid | None,
    vantage: Vantage | None,
    assets: GeneratedAssets,
    rooms: list[RoomDescription],
    robots: Sequence[Robot],
    state: dict[str, RobotState],
    playback: PlaybackMessage | None,
    backend: Backend,
) -> HelloMessage:
    return {
        "identifier": "hello",
        "protocol": PROTOCOL_VERSION,
        "server": {"name": SERVER_NAME, "version": __version__},
        "client_id": client_id,
        "role": role,
        "scene": {"url": assets.scene_url, "map_to_scene": assets.map_to_scene()},
        "bounds": list(grid.bounds) if grid is not None else None,
        "vantage": None if vantage is None else {"x": vantage.x, "y": vantage.y, "yaw": vantage.yaw},
        "rooms": rooms,
        "robots": [describe_robot(r, assets.model_urls.get(r.name)) for r in robots],
        "state": state,
        "playback": playback,
        "backend": backend_message(backend.name, backend.failure),
    }
