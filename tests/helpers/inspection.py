"""The inspection tests' relay with a database of its own, an operator on it, and the missions a client was told of."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from relay.cli.options import Options
from relay.config import FleetConfig
from relay.inspection.records import AlertRecord
from relay.inspection.store import Store
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


async def stored_alert(running: RunningRelay, alert_id: str) -> AlertRecord | None:
    """An alert as the relay's database holds it, read on a connection of the test's own (the relay's connection
    is its store thread's)."""
    store = running.relay.inspection.store
    assert store is not None, "the relay has no database"

    def read() -> AlertRecord | None:
        with Store.open(store.name, store.images) as own:
            return own.alert(alert_id)

    return await asyncio.to_thread(read)
