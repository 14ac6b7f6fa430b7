"""Missions read from their files, assigned and checked step by step on the planning pool, never on the loop: a
refusal is the ``error`` the client gets (``busy`` when the pool's queue is full)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import CommandRejected
from ..session.protocol import ErrorCode, RequestId
from ..station.work import Busy, WorkPool
from .kml import KmlError, targets_from_kml
from .missions import MissionError, MissionPlan, Waypoint, assign, load_mission, resolve, steps_from_wire
from .records import Step, Target
from .targets import TARGET_ID
from .wire import MissionStart

if TYPE_CHECKING:
    from ..config import FleetConfig
    from ..fleet.occupancy import OccupancyGrid

Position = tuple[float, float]


class MissionPlanning:
    """Plans on ``pool`` (a thread of its own and a bounded queue), against the map and the site's ``targets``."""

    def __init__(
        self,
        config: FleetConfig,
        missions_dir: Path,
        pool: WorkPool,
        *,
        targets: Mapping[str, Target],
        map_grid: Callable[[], OccupancyGrid | None],
    ) -> None:
        self._config = config
        self._missions_dir = missions_dir
        self._pool = pool
        self._targets = targets  # read-only here: the target book changes it
        self._map_grid = map_grid

    async def plan(self, command: MissionStart) -> tuple[MissionPlan, list[Target]]:
        """The mission asked for, and the targets its file brings (KML/KMZ placemarks): a file is read and parsed
        on the planning pool (a 6000-placemark KMZ once held the loop, and an estop, for 9.8 s)."""
        try:
            if command.file is not None:
                file = command.file
                return await self._pool.run(lambda: self._mission_file(file))
            name = command.name or "mission"
            if command.targets is not None:
                return MissionPlan(name, targets=command.targets), []
            assert command.robot is not None
            return MissionPlan(name, robots=((command.robot, steps_from_wire(command.steps, "mission/start")),)), []
        except (MissionError, KmlError) as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, str(exc), command.id) from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"mission/start: {exc}; try again shortly", command.id) from None

    def _mission_file(self, name: str) -> tuple[MissionPlan, list[Target]]:
        """``missions/<name>.yaml``, or ``<name>.kmz``/``.kml``: its placemarks are targets, visited by the fleet.
        Runs on the planning pool: reads files and the config only."""
        if not TARGET_ID.match(name):
            raise MissionError(f"mission/start: no mission file named {name[:64]!r}")
        folder = self._missions_dir
        for suffix in (".yaml", ".kmz", ".kml"):
            path = folder / f"{name}{suffix}"
            if not path.is_file():
                continue
            if suffix == ".yaml":
                return load_mission(path), []
            targets = targets_from_kml(path.read_bytes(), path.name, self._config.georeference)
            if not targets:
                raise MissionError(f"{path.name}: no placemark with a point: nothing to inspect")
            return MissionPlan(name, targets=tuple(t.id for t in targets)), targets
        available = sorted({p.stem for p in folder.glob("*") if p.suffix in (".yaml", ".kmz", ".kml")})
        raise MissionError(f"mission/start: no mission file {name!r}; there are {', '.join(available) or 'none'}")

    async def assign(
        self, targets: tuple[str, ...], positions: dict[str, Position], request_id: RequestId
    ) -> dict[str, tuple[Step, ...]]:
        """The targets shared out among the robots at ``positions``: each robot's inspect steps."""
        where = dict(self._targets)
        try:
            assigned = await self._pool.run(lambda: assign(targets, positions, where))
        except MissionError as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"mission/start: {exc}", request_id) from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"mission/start: {exc}; try again shortly", request_id) from None
        return {r: tuple(Step("inspect", target=t) for t in ts) for r, ts in assigned.items()}

    async def check(
        self,
        robots: dict[str, tuple[Step, ...]],
        starts: dict[str, Position],
        identifier: str,
        request_id: RequestId,
    ) -> dict[str, list[Waypoint | None]]:
        """Every step of every robot checked, from where each stands (``starts``), on the planning pool."""
        grid = self._map_grid()
        where = dict(self._targets)

        def check() -> dict[str, list[Waypoint | None]]:
            planner = _planner(grid)
            return {r: resolve(r, steps, where, starts[r], grid, planner) for r, steps in robots.items()}

        try:
            return await self._pool.run(check)
        except MissionError as exc:
            raise CommandRejected(ErrorCode.NO_PATH, f"{identifier}: {exc}", request_id) from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"{identifier}: {exc}; try again shortly", request_id) from None


def _planner(grid: OccupancyGrid | None) -> Any:
    if grid is None:
        return None
    from ..sim.planner import Planner

    return Planner(grid, 0.25)
