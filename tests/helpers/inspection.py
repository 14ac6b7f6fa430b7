"""The inspection tests' relay with a database of its own, an operator on it, and the missions a client was told of."""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import pytest

from relay.cli.options import Options
from relay.config import FleetConfig, Lens
from relay.inspection.change import SCORE_THRESHOLD, compare, decode
from relay.inspection.records import AlertRecord, CaptureRecord, FindingRecord
from relay.inspection.segment import outline_of
from relay.inspection.store import Store
from relay.sim.camera import SimCamera, embree_available, rgb_to_jpeg
from relay.sim.floorplan import demo_facility
from relay.sim.spill import GrownSpill
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.wsclient import TestClient

TOKEN = "op"
T = TypeVar("T")


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
    """An alert as the relay's database holds it."""
    return await _stored(running, lambda store: store.alert(alert_id))


async def stored_finding(running: RunningRelay, finding_id: str) -> FindingRecord | None:
    """A finding as the relay's database holds it."""
    return await _stored(running, lambda store: store.finding(finding_id))


async def _stored(running: RunningRelay, read: Callable[[Store], T]) -> T:
    """Read the relay's database on a connection of the test's own (the relay's connection is its store thread's)."""
    store = running.relay.inspection.store
    assert store is not None, "the relay has no database"

    def on_own() -> T:
        with Store.open(store.name, store.images) as own:
            return read(own)

    return await asyncio.to_thread(on_own)


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


async def two_rounds(running: RunningRelay) -> tuple[FindingRecord, FindingRecord, FindingRecord]:
    """Round one (mission m-pins-1): the spill as it was, ok. Round two (m-pins-2): the spill grown, ``changed`` with
    the relay's score against round one, and the panels beside it unchanged (ok)."""
    if not embree_available():
        pytest.skip("the simulated camera's renders need Embree (embreex, installed by make setup)")
    captures: Any = running.relay.inspection.captures
    first, later, score, outline = await asyncio.to_thread(spill_rounds)
    assert score > SCORE_THRESHOLD and outline is not None, score
    now = time.time()
    rounds = ("m-pins-1.robot1", "m-pins-2.robot1")
    stored = []
    for index, jpeg in enumerate((first, later)):
        record = CaptureRecord(f"c-pins-{index}", "robot1", now - 60 + 60 * index, *SPILL_VIEW, {}, rounds[index],
                               "spill", None, SIZE, SIZE)  # fmt: skip
        stored.append(await captures._store(lambda s, r=record, j=jpeg: s.add_capture(r, j)))
    before, after = stored
    old = FindingRecord("f-pins-0", before.id, "robot1", 1.8, 8.2, "ok", "within thresholds", "rule", before.t,
                        before.t, rounds[0], "spill")  # fmt: skip
    changed = FindingRecord("f-pins-1", after.id, "robot1", 1.8, 8.2, "changed", "changed since the last round",
                            "rule", after.t, after.t, rounds[1], "spill", outline, round(score, 4),
                            before.id)  # fmt: skip
    same = FindingRecord("f-pins-2", after.id, "robot1", 4.0, 8.2, "ok", "within thresholds", "rule", after.t + 1,
                         after.t + 1, rounds[1], "panels")  # fmt: skip
    for finding in (old, changed, same):
        capture = before if finding is old else after
        await captures._announce(await captures._store(lambda s, f=finding: s.add_finding(f)), capture)
    return old, changed, same
