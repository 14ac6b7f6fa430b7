"""Latency in view (issue #31, item 4), the relay's half: how late each robot's poses, pictures and commands are where
the relay sees them, per robot and stage, in /metrics (relay/fleet/latency.py). The rules with a wall clock moved by
hand, then a real relay on the simulated fleet with a client that drives and watches a camera."""

from __future__ import annotations

import asyncio
import re

import aiohttp

from relay.fleet.latency import SAMPLES, StageLatency
from tests.conftest import LOAD_SLACK, RunningRelay
from tests.wsclient import TestClient


class Wall:
    def __init__(self) -> None:
        self.t = 1_700_000_000.0

    def __call__(self) -> float:
        return self.t


def test_each_stage_is_the_median_of_its_recent_figures_and_other_clocks_do_not_count() -> None:
    wall = Wall()
    latency = StageLatency(wall)
    for late in (0.02, 0.03, 0.9):  # one late pose among quick ones: the median stays with the quick ones
        latency.stamped("robot1", "pose", wall.t - late)
    latency.stamped("robot1", "picture", wall.t - 100_000)  # a recording's stamp: another clock
    latency.stamped("robot1", "picture", wall.t + 5)  # a robot clock five seconds ahead
    latency.stamped("robot2", "picture", wall.t + 0.1)  # within the clocks' agreement: counted as 0
    latency.took("robot2", "command", 0.012)
    medians = latency.medians()
    assert abs(medians[("robot1", "pose")] - 0.03) < 1e-6
    assert ("robot1", "picture") not in medians
    assert medians[("robot2", "picture")] == 0.0 and medians[("robot2", "command")] == 0.012
    for _ in range(3 * SAMPLES):  # the recent figures only: an hour-old slow spell is forgotten
        latency.took("robot2", "command", 0.5)
    assert latency.medians()[("robot2", "command")] == 0.5


async def test_metrics_export_each_robots_pose_picture_and_command_latency(relay_server: RunningRelay) -> None:
    client = await TestClient.open(relay_server.ws_url)
    await client.hello()
    assert (await client.request({"identifier": "robot3/stream", "camera": "front", "fps": 5}))["identifier"] == "ack"
    pattern = re.compile(r'xr_relay_latency_seconds\{robot="(\w+)",stage="(\w+)"\} ([0-9.e-]+)')
    figures: dict[tuple[str, str], float] = {}

    async def scrape() -> None:
        async with aiohttp.ClientSession() as http, http.get(f"{relay_server.url}/metrics") as response:
            text = await response.text()
        figures.clear()
        figures.update({(m[1], m[2]): float(m[3]) for m in pattern.finditer(text)})

    async def drive_and_scrape() -> bool:
        await client.send({"identifier": "robot1/cmd_vel", "linear": 0.1, "angular": 0.0})
        await scrape()
        return {("robot1", "pose"), ("robot3", "picture"), ("robot1", "command")} <= set(figures)

    for _ in range(int(40 * (1 + LOAD_SLACK))):  # 20 Hz as teleop drives; a scrape each time
        if await drive_and_scrape():
            break
        await asyncio.sleep(0.05)
    await client.send({"identifier": "robot1/cmd_vel", "linear": 0.0, "angular": 0.0})
    assert {("robot1", "pose"), ("robot3", "picture"), ("robot1", "command")} <= set(figures), figures
    # Every robot's pose is counted, and every figure is a latency, not a clock difference: under a few seconds.
    await scrape()
    assert all((r, "pose") in figures for r in ("robot1", "robot2", "robot3")), figures
    assert all(0.0 <= value < 5.0 for value in figures.values()), figures
    await client.close()
