"""The live 3D map's e2e tests' common ground: where the sim's robots drive to map the facility, and the map points a
pointer aims at (tests/e2e/test_map3d_desktop.py, test_map3d_vr.py)."""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import math
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

import numpy as np
from playwright.async_api import Error as PlaywrightError

from relay.config import Cloud, load_config
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.browser import Client, wait_until

#: Each robot into its room (robots.yaml's start poses are in the corridor).
GOALS = {"robot1": (3.0, 7.0), "robot2": (9.0, 7.0), "robot3": (15.0, 7.0)}


@contextlib.asynccontextmanager
async def mapping_relay() -> AsyncIterator[RunningRelay]:
    """The demo fleet's relay with its live 3D map on (10 cm voxels: SwiftShader draws a few thousand boxes in a frame
    it can screenshot; at 5 cm the same drive made 95 000, 1.1 M triangles, seconds a frame on a loaded CI machine),
    each robot sent into its room (GOALS) to map it."""
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(dataclasses.replace(config, cloud=Cloud(voxel=0.1, sim_depth_rate=2.0)))
    try:
        for robot, (x, y) in GOALS.items():
            await running.relay.backend.send_goal(robot, x, y, None)
        yield running
    finally:
        await running.runner.cleanup()


def map_spots(
    running: RunningRelay, occupied: np.ndarray, voxel: float
) -> tuple[list[tuple[float, float]], tuple[float, float]]:
    """The map points on floor the robots saw (each the middle of a 5 x 5 patch of floor voxels with nothing above
    it), and one point on the facility's free floor that the map has nothing near: all clear of the robots."""
    floor = {(int(i), int(j)) for i, j, k in occupied if k == 0}
    above = {(int(i), int(j)) for i, j, k in occupied if 0 < k < 25}
    grid = running.relay.map_grid()
    assert grid is not None
    robots = list(running.relay.fleet.positions(time.monotonic()).values())

    def clear(x: float, y: float) -> bool:
        return grid.is_free(x, y) and all(math.dist(p, (x, y)) > 0.8 for p in robots)

    patch = [(di, dj) for di in range(-2, 3) for dj in range(-2, 3)]
    seen = [
        ((i + 0.5) * voxel, (j + 0.5) * voxel)
        for i, j in sorted(floor)
        if all((i + di, j + dj) in floor and (i + di, j + dj) not in above for di, dj in patch)
        and clear((i + 0.5) * voxel, (j + 0.5) * voxel)
    ]
    assert seen, "no patch of floor the robots saw"
    columns = floor | above
    reach = int(0.5 / voxel)
    x0, y0, x1, y1 = grid.bounds
    unseen = next(
        (x, y)
        for x in np.arange(x0 + 0.5, x1 - 0.5, 0.25)
        for y in np.arange(y0 + 0.5, y1 - 0.5, 0.25)
        if clear(x, y)
        and not any(
            (int(x / voxel) + di, int(y / voxel) + dj) in columns
            for di in range(-reach, reach + 1)
            for dj in range(-reach, reach + 1)
        )
    )
    return seen, (float(unseen[0]), float(unseen[1]))


async def goal_at_relay(client: Client, running: RunningRelay, robot: str, press: Callable[[], Awaitable[Any]]) -> Any:
    """``press`` the page's goal (a click, a trigger) until the relay holds a goal for ``robot``, at most three
    times, as an operator would press again: a press read just after a stall of the loop is dropped as stale, and one
    the page did not send (its link down, the pointer elsewhere) is said in the failure."""

    def goal() -> Any:
        return running.relay.fleet.status(robot, time.monotonic())["goal"]

    missed: list[Any] = []
    for _ in range(3):
        await client.wait("s.connected", 30)  # a press while the link is down sends nothing (the page says so)
        before = (await client.state())["goal"]["sent"]
        await press()
        try:
            await client.wait("s.goal.sent > arg", 20, before)
        except PlaywrightError:
            # Not sent: what the page knew then, for the failure's message; an operator would press again.
            s = await client.state()
            missed.append({k: s[k] for k in ("connected", "pongAt", "goal", "menu")})
            continue
        with contextlib.suppress(AssertionError):
            await wait_until(lambda: goal() is not None, 20, f"{robot}'s goal at the relay")
            break
    sent = goal()
    assert sent is not None, f"{robot} has no goal at the relay after three presses; presses not sent: {missed}"
    return sent
