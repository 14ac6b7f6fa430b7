"""Assets the relay builds at run time and serves under ``/scenes/generated``: twins of live maps, robot models.

Both are built off the loop (``asyncio.to_thread``), once per distinct input (named by a digest of it), and only
the newest of each kind is kept: a client that loads it later must find it, older ones are stale.
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import time
from collections.abc import Coroutine, Mapping
from typing import Any

from ..config import Robot, Scene
from ..fleet.events import MapEvent, RobotModelEvent
from ..twin.map_twin import grid_to_glb
from ..twin.urdf import robot_description_glb
from .messages import Transform2D, model_message, scene_message
from .outbox import Outbox

logger = logging.getLogger(__name__)

#: Where twins built from live maps and models built from robot descriptions are served.
GENERATED_SCENES = "/scenes/generated"


def map_digest(event: MapEvent) -> str:
    """Names a map by its content, so that a re-published latched /map is not rebuilt."""
    grid = event.grid
    return hashlib.sha256(
        grid.occupied.tobytes()
        + (event.unknown.tobytes() if event.unknown is not None else b"")
        + repr((grid.origin_x, grid.origin_y, grid.resolution, grid.occupied.shape)).encode()
    ).hexdigest()[:12]


class GeneratedAssets:
    def __init__(self, scene: Scene, robots: Mapping[str, Robot], outbox: Outbox) -> None:
        self._scene = scene
        self._robots = robots
        self._outbox = outbox
        #: File name -> GLB bytes, served by relay.net.server.
        self.files: dict[str, bytes] = {}
        #: The twin clients load: robots.yaml's, or one built from a live map.
        self.scene_url: str | None = scene.url
        #: Robots whose model was built from their robot_description.
        self.model_urls: dict[str, str] = {}
        self._pending_map: MapEvent | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self._twin_task: asyncio.Task[None] | None = None

    def map_to_scene(self) -> Transform2D:
        m = self._scene.map_to_scene
        return {"x": m.x, "y": m.y, "z": m.z, "yaw": m.yaw}

    def on_map(self, event: MapEvent) -> None:
        """A live /map: it becomes the twin when robots.yaml names none (the newest map wins)."""
        if self._scene.url is not None:
            return
        self._pending_map = event
        if self._twin_task is None or self._twin_task.done():
            self._twin_task = self._spawn(self._build_twins(), "map-twin")

    def on_model(self, event: RobotModelEvent) -> None:
        self._spawn(self._build_model(event), f"model-{event.robot}")

    def close(self) -> None:
        for task in list(self._tasks):
            task.cancel()

    def _spawn(self, coro: Coroutine[Any, Any, None], name: str) -> asyncio.Task[None]:
        task = asyncio.get_running_loop().create_task(coro, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    def _replace(self, prefix: str, name: str, glb: bytes) -> str:
        for old in [k for k in self.files if k.startswith(prefix)]:
            del self.files[old]
        self.files[name] = glb
        return f"{GENERATED_SCENES}/{name}"

    async def _build_twins(self) -> None:
        """Turn the newest map into a twin, then the next one if another arrived meanwhile."""
        while self._pending_map is not None:
            event, self._pending_map = self._pending_map, None
            name = f"map-{map_digest(event)}.glb"
            if name in self.files:
                continue  # the same map again: nothing to rebuild
            started = time.monotonic()
            try:
                glb = await asyncio.to_thread(grid_to_glb, event.grid, unknown=event.unknown)
            except ValueError as exc:
                logger.error("could not build a twin from the map: %s", exc)
                continue
            self.scene_url = self._replace("map-", name, glb)
            logger.info(
                "twin of the map built in %.2f s (%d kB): %s",
                time.monotonic() - started,
                len(glb) // 1024,
                self.scene_url,
            )
            scene = scene_message(self.scene_url, self.map_to_scene())
            self._outbox.broadcast(scene)

    async def _build_model(self, event: RobotModelEvent) -> None:
        """A robot's URDF becomes its glTF model (once per distinct description)."""
        spec = self._robots[event.robot]
        name = f"robot-{event.robot}-{hashlib.sha256(event.urdf.encode()).hexdigest()[:12]}.glb"
        if name in self.files:
            return
        packages = list(spec.model_source.packages) if spec.model_source is not None else []
        namespace = spec.namespace.strip("/")
        glb = await asyncio.to_thread(
            robot_description_glb, event.urdf, packages, namespace=f"{namespace}/" if namespace else ""
        )
        url = self._replace(f"robot-{event.robot}-", name, glb)
        self.model_urls[event.robot] = url
        logger.info("model of %s from its robot_description: %s (%d kB)", event.robot, url, len(glb) // 1024)
        self._outbox.broadcast(model_message(event.robot, url))
