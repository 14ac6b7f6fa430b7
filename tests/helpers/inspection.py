"""The inspection tests' relay with a database of its own, an operator on it, and the missions a client was told of."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path
from typing import Any

from relay.cli.options import Options
from relay.config import FleetConfig, Lens
from relay.inspection.change import compare, decode
from relay.inspection.records import AlertRecord
from relay.inspection.segment import outline_of
from relay.inspection.store import Store
from relay.sim.camera import SimCamera, rgb_to_jpeg
from relay.sim.floorplan import demo_facility
from relay.sim.spill import GrownSpill
from tests.conftest import ROOT, RunningRelay, start_relay
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


#: The spill's standoff, facing north (the demo round's view of it), and the simulated camera's lens.
SPILL_VIEW = (1.8, 7.4, math.pi / 2)
SIZE = 320


def spill_rounds() -> tuple[bytes, bytes, float, tuple[tuple[int, int], ...] | None]:
    """Two rounds' pictures of the spill as the simulator renders them (scenes/facility.glb through the demo's
    fisheye), the spill as it was and grown twice its size, and what the relay's comparison makes of them: the
    change score and the outline of what changed, as relay/inspection/change_watch.py computes them."""
    camera = SimCamera.load(ROOT / "scenes" / "facility.glb")
    lens = camera.fit_lens(Lens("equidistant", 180.0), SIZE, SIZE)
    decal = next(d for d in demo_facility().decals if d.kind == "spill")
    first, later = (rgb_to_jpeg(camera.render(*SPILL_VIEW, lens, spill=GrownSpill(decal, k))) for k in (1.0, 2.0))
    change = compare(decode(first, "the first round"), decode(later, "the second round"))
    return first, later, change.score, outline_of(change.mask, SIZE, SIZE)
