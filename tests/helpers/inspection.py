"""The inspection tests' relay with a database of its own, an operator on it, and the missions a client was told of."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from relay.cli.options import Options
from relay.config import FleetConfig
from tests.conftest import RunningRelay, start_relay
from tests.wsclient import TestClient

TOKEN = "op"


async def relay_with_database(fleet_config: FleetConfig, tmp_path: Path, **options: Any) -> RunningRelay:
    return await start_relay(
        fleet_config,
        options=Options(token=TOKEN, allow_viewers=True, database=str(tmp_path / "inspection.sqlite"), **options),
    )


async def operator(running: RunningRelay) -> TestClient:
    client = await TestClient.open(f"{running.ws_url}?token={TOKEN}")
    await client.hello()
    return client


def missions(client: TestClient) -> dict[str, dict[str, Any]]:
    """The newest `mission` message of each mission this client received."""
    latest: dict[str, dict[str, Any]] = {}
    for _, message in client.messages:
        if message["identifier"] == "mission":
            latest[message["id"]] = message
    return latest
