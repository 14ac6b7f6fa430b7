"""relay.session.budget and relay.station.work: snapshots per role, per client and in total (operators always keep a
slot), and work pools of their own with bounded queues."""

from __future__ import annotations

import asyncio
import threading
import time

import pytest

from relay.backends.sim import SimBackend
from relay.config import FleetConfig
from relay.errors import CommandRejected
from relay.session.budget import IN_FLIGHT, INTERVAL, OPERATOR_RESERVE, TOTAL, SnapshotBudget
from relay.station.work import Busy, WorkPool
from tests.conftest import LOAD_SLACK


def test_a_viewer_takes_one_snapshot_at_a_time_and_one_a_second() -> None:
    budget = SnapshotBudget()
    assert budget.take("v1", "viewer", 10.0) is None
    assert "already in progress" in (budget.take("v1", "viewer", 12.0) or "")
    budget.done("v1", "viewer")
    assert "one snapshot every 1 s" in (budget.take("v1", "viewer", 10.5) or "")
    assert budget.take("v1", "viewer", 10.0 + INTERVAL["viewer"]) is None


def test_viewers_together_cannot_take_the_operators_reserve() -> None:
    budget = SnapshotBudget()
    viewers = [f"v{i}" for i in range(TOTAL)]
    taken = [v for v in viewers if budget.take(v, "viewer", 0.0) is None]
    assert len(taken) == TOTAL - OPERATOR_RESERVE
    assert "kept for operators" in (budget.take("v-last", "viewer", 0.0) or "")
    # The operator still gets its snapshots, up to its own limit.
    assert budget.take("op", "operator", 0.0) is None
    assert budget.take("op", "operator", 0.0) is None  # two cameras at once
    assert IN_FLIGHT["operator"] == 2 and "already in progress" in (budget.take("op", "operator", 1.0) or "")
    assert "taking 4 snapshots already" in (budget.take("op2", "operator", 1.0) or "")
    for v in taken:
        budget.done(v, "viewer")
    assert budget.take("v-last", "viewer", 2.0) is None and budget.total == 3


async def test_a_work_pool_refuses_beyond_its_queue_and_recovers() -> None:
    pool = WorkPool("rendering", workers=1, queue=1)
    gate = threading.Event()
    jobs = [asyncio.ensure_future(pool.run(gate.wait)) for _ in range(2)]
    await asyncio.sleep(0)
    with pytest.raises(Busy, match="rendering pool is full"):
        await pool.run(lambda: None)
    gate.set()
    assert await asyncio.gather(*jobs) == [True, True]
    assert await pool.run(lambda: 42) == 42
    pool.shutdown()


async def test_the_sim_plans_goals_while_its_rendering_pool_is_full(fleet_config: FleetConfig) -> None:
    # Viewers' renders once shared asyncio's default pool with goal planning: enough of them and a goal waited.
    backend = SimBackend(fleet_config, lambda event: None)
    await backend.start()
    gate = threading.Event()
    try:
        rendering = backend.cameras._rendering
        fills = [asyncio.ensure_future(rendering.run(gate.wait)) for _ in range(rendering.capacity)]
        await asyncio.sleep(0)
        with pytest.raises(CommandRejected) as refused:
            await backend.snapshot("robot1", "front")
        assert refused.value.code == "busy"
        started = time.monotonic()
        await asyncio.wait_for(backend.send_goal("robot1", 3.0, 6.0, None), 5 + LOAD_SLACK)
        assert time.monotonic() - started < 2.0 + LOAD_SLACK  # planned at once, not after the renders (never done)
        assert backend.world.robots["robot1"].follower is not None, "the robot has no path to follow"
    finally:
        gate.set()
        await asyncio.gather(*fills)
        await backend.stop()
