"""Schedules' tests on a real relay (tests/test_schedules.py, tests/test_schedule_cli.py): the relay with its time of
day moved by hand, and the schedules as its clients hear them."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from aiohttp import web

from relay.cli.options import Options
from relay.config import FleetConfig
from relay.net.server import RELAY_KEY, create_app, open_runner
from tests.conftest import RunningRelay
from tests.helpers.inspection import TOKEN
from tests.wsclient import TestClient

#: Seconds: generous for a loaded 2-core machine (the scheduler beats once a second); never waited out when all is well.
WAIT = 30.0
EVERY_DAY = [{"days": ["mon", "tue", "wed", "thu", "fri", "sat", "sun"], "hours": [0, 24]}]


class HandClock:
    """The relay's time of day, moved by the test."""

    def __init__(self, now: float) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


async def schedule_relay(
    fleet_config: FleetConfig, tmp_path: Path, clock: HandClock, missions_dir: Path | None = None
) -> RunningRelay:
    options = Options(token=TOKEN, allow_viewers=True, database=str(tmp_path / "inspection.sqlite"))
    if missions_dir is not None:
        options = dataclasses.replace(options, missions_dir=missions_dir)
    app = create_app(fleet_config, options, wall_clock=clock)
    runner = await open_runner(app)
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    host, port = runner.addresses[0][:2]
    return RunningRelay(f"http://{host}:{port}", f"ws://{host}:{port}/ws", app[RELAY_KEY], runner)


async def ask(client: TestClient, message: dict[str, Any]) -> dict[str, Any]:
    """A command's ack or error, within the margin a loaded machine needs (the client's default is 5 s)."""
    return await client.request(message, WAIT)


def listed_schedules(client: TestClient) -> dict[str, dict[str, Any]]:
    """The schedules as the newest `schedules` message this client got lists them."""
    latest = [m for _, m in client.messages if m["identifier"] == "schedules"]
    return {s["schedule"]: s for s in latest[-1]["schedules"]} if latest else {}


async def schedule_state(client: TestClient, name: str, check: Any) -> dict[str, Any]:
    """The first `schedules` message (from now on, or the newest) whose entry ``name`` passes ``check``."""
    message = await client.wait_for(
        lambda m: m["identifier"] == "schedules" and any(s["schedule"] == name and check(s) for s in m["schedules"]),
        WAIT,
    )
    return next(s for s in message["schedules"] if s["schedule"] == name)
