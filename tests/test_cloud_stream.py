"""The live 3D map over /ws (issue #33): a new client gets the whole map first, then only the blocks that changed.

A real relay on loopback port 0 (sim backend, its depth cameras off so that the test feeds known clouds through the
relay's own event path), its real fusion and hub, real WebSocket clients."""

from __future__ import annotations

import asyncio
import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np

from relay.cloud.blocks_wire import WireBlock, decode_blocks
from relay.config import Cloud, load_config
from relay.fleet.events import CloudEvent
from tests.conftest import RunningRelay, start_relay
from tests.wsclient import TestClient

ROOT = Path(__file__).resolve().parents[1]


def _wall(x: float, y0: float) -> CloudEvent:
    """A patch of wall 0.6 x 0.6 m at ``x``, seen from the origin (1 cm apart: ~3600 points)."""
    y, z = np.meshgrid(np.arange(y0, y0 + 0.6, 0.01), np.arange(0.0, 0.6, 0.01))
    points = np.stack([np.full(y.size, x), y.ravel(), z.ravel()], axis=1).astype(np.float32)
    return CloudEvent("robot1", time.time(), points, np.eye(4))


def _batches(client: TestClient) -> list[tuple[dict[str, Any], list[WireBlock]]]:
    """Each ``voxel_map`` message with the records of the frames it announced, in order."""
    out, used = [], 0
    for _, message in client.messages:
        if message["identifier"] == "voxel_map":
            frames = client.voxel_frames[used : used + message["frames"]]
            used += message["frames"]
            out.append((message, [block for frame in frames for block in decode_blocks(frame)]))
    return out


async def _batch(client: TestClient, count: int, timeout: float = 10.0) -> list[tuple[dict[str, Any], list[WireBlock]]]:
    """The first ``count`` batches, once they and all their frames arrived."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        batches = _batches(client)
        if len(batches) >= count and all(len(blocks) == m["blocks"] for m, blocks in batches[:count]):
            return batches[:count]
        await asyncio.sleep(0.05)
    raise AssertionError(f"{len(_batches(client))} voxel_map batches, expected {count}")


async def _fused(running: RunningRelay, version: int) -> None:
    assert running.relay.fusion is not None
    for _ in range(200):
        if running.relay.fusion.version >= version:
            return
        await asyncio.sleep(0.05)
    raise AssertionError(f"the map is at version {running.relay.fusion.version}, expected {version}")


def _held(batches: list[tuple[dict[str, Any], list[WireBlock]]]) -> dict[tuple[int, int, int], list[tuple[int, ...]]]:
    """The blocks a client holds after applying ``batches`` as docs/protocol.md says: index -> sorted voxels."""
    held: dict[tuple[int, int, int], list[tuple[int, ...]]] = {}
    for message, blocks in batches:
        if message["reset"]:
            held.clear()
        for block in blocks:
            if len(block.local):
                held[block.index] = sorted(map(tuple, block.local.tolist()))
            else:
                held.pop(block.index, None)
    return held


async def test_a_new_client_gets_the_whole_map_then_only_changes() -> None:
    config = dataclasses.replace(load_config(ROOT / "robots.yaml"), cloud=Cloud(sim_depth_rate=0.0))
    running = await start_relay(config)
    clients: list[TestClient] = []
    try:
        running.relay.on_event(_wall(2.0, 0.0))
        await _fused(running, 1)
        first = await TestClient.open(running.ws_url)
        clients.append(first)
        await first.hello()
        [(whole, blocks)] = await _batch(first, 1)
        assert whole["since"] == 0 and whole["reset"] and whole["version"] == 1 and whole["voxel"] == 0.05
        assert blocks and {b.index[0] for b in blocks} == {2}  # x = 2.0 m is block 2 of 0.8 m
        assert sum(len(b.local) for b in blocks) == 12 * 12  # 0.6 x 0.6 m of 5 cm voxels

        # Another wall, behind the robot: only its blocks come, from the version the client holds.
        running.relay.on_event(_wall(-3.0, 2.0))
        await _fused(running, 2)
        [_, (change, changed)] = await _batch(first, 2)
        assert change["since"] == 1 and not change["reset"] and change["version"] == 2
        assert changed and {b.index[0] for b in changed} == {-4}
        assert all(b.version == 2 for b in changed)

        # A client that connects now gets the whole map at once, the same as the first one holds.
        second = await TestClient.open(running.ws_url)
        clients.append(second)
        await second.hello()
        [(late, _)] = await _batch(second, 1)
        assert late["since"] == 0 and late["reset"] and late["version"] == 2
        assert _held(await _batch(second, 1)) == _held(await _batch(first, 2))
        assert len(_held(await _batch(second, 1))) == len(blocks) + len(changed)
    finally:
        for client in clients:
            await client.close()
        await running.runner.cleanup()
