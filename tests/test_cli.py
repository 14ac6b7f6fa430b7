"""The command a user runs: ``xr-relay`` / ``python -m relay`` in its own process."""

from __future__ import annotations

import asyncio
import signal
import socket
import subprocess
import sys
import time

import aiohttp
import pytest

from tests.conftest import LOAD_SLACK, ROOT, Canary, SlowCallbackCollector, own_files
from tests.helpers.cli import start_process
from tests.wsclient import TestClient


def test_help_documents_every_option() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "relay", "--help"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    for option in ("--config", "--backend", "--host", "--port", "--log-level", "sim", "ros", "bag"):
        assert option in out


async def test_relay_process_serves_and_stops_cleanly_on_ctrl_c() -> None:
    process, url, ws_url = await start_process()
    try:
        async with aiohttp.ClientSession() as http, http.get(f"{url}/healthz") as response:
            health = await response.json()
        assert health["backend"] == "sim" and health["robots_online"] in (0, 1, 2, 3)
        client = await TestClient.open(ws_url)
        hello = await client.hello()
        assert [r["name"] for r in hello["robots"]] == ["robot1", "robot2", "robot3"]
        for _ in range(5):
            await client.send({"identifier": "robot1/cmd_vel", "linear": 0.5, "angular": 0.0})
            await asyncio.sleep(0.05)
        sent_at = time.monotonic()
        process.send_signal(signal.SIGINT)
        status = await asyncio.wait_for(process.wait(), 30)
        assert time.monotonic() - sent_at < 2.0 + LOAD_SLACK  # server.SHUTDOWN_TIMEOUT's 2 s, not aiohttp's 60
        assert status == 0
        await asyncio.wait_for(client._reader, 2)
        assert client.closed_code == 1001
        assert process.stderr is not None
        log = (await process.stderr.read()).decode()
        assert "all robots stopped (relay shutting down)" in log
        assert "Traceback" not in log
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()


def test_busy_port_exits_with_status_2() -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        result = subprocess.run(
            [sys.executable, "-m", "relay", "--port", str(port), *own_files()],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert result.returncode == 2 and f"cannot listen on 127.0.0.1:{port}" in result.stderr


@pytest.mark.allow_blocking
@pytest.mark.parametrize("how", ["sleep", "compute"])
async def test_the_loop_blocking_check_catches_a_blocking_call(
    loop_block_collector: SlowCallbackCollector, how: str
) -> None:
    """The autouse check is real: a synchronous sleep or a long computation on the loop is reported."""
    canary = Canary()
    canary.start()
    await asyncio.sleep(0.05)
    if how == "sleep":
        time.sleep(1.5)  # noqa: ASYNC251 - blocking on purpose
    else:
        # 1.5 s of CPU, not of the clock: on a busy machine the loop's thread waits for a CPU part of the time,
        # which the check does not count against a callback.
        end = time.thread_time() + 1.5
        while time.thread_time() < end:
            sum(range(1000))
    await asyncio.sleep(0.05)
    canary.running = False
    blocking = loop_block_collector.blocking(canary)
    assert blocking and "took" in blocking[0]


async def test_the_loop_refuses_scheduling_from_another_thread() -> None:
    """The autouse check's other half: a relay thread must hand work over with call_soon_threadsafe."""
    loop = asyncio.get_running_loop()
    errors: list[BaseException] = []

    def from_a_thread() -> None:
        try:
            loop.call_soon(lambda: None)
        except RuntimeError as error:
            errors.append(error)

    await asyncio.to_thread(from_a_thread)
    assert errors and "thread" in str(errors[0])
