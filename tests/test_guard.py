"""Connections before they are admitted (relay.net.guard), and the Host check against DNS rebinding.

Slowloris connections are closed at their header deadline, a flood of half-open connections evicts itself
(never the admitted operator), a relay short of descriptors still lets the operator in and logs accept failures
once per interval, and a Host that is not one of the relay's names is refused.
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time
from pathlib import Path

import aiohttp
import pytest

from relay.cli.options import Options
from relay.config import FleetConfig
from relay.net.guard import ACCEPT_FAILURE, ConnectionGuard
from tests.conftest import LOAD_SLACK, RunningRelay, relay_process, start_relay
from tests.wsclient import TestClient

TOKEN = "operator-secret"


async def open_raw(
    running: RunningRelay, first_bytes: bytes = b""
) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    host, port = running.url.removeprefix("http://").split(":")
    reader, writer = await asyncio.open_connection(host, int(port))
    if first_bytes:
        writer.write(first_bytes)
        await writer.drain()
    return reader, writer


async def answers_ping(client: TestClient) -> None:
    start = len(client.messages)
    await client.send({"identifier": "ping", "t": 7})
    await client.wait_for(lambda m: m["identifier"] == "pong" and m["t"] == 7, start=start)


async def closed_by_relay(reader: asyncio.StreamReader, timeout: float) -> bool:
    try:
        return await asyncio.wait_for(reader.read(1024), timeout) == b""
    except TimeoutError:
        return False
    except ConnectionError:
        return True


async def test_slowloris_connections_are_closed_at_the_header_deadline(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config, options=Options(token=TOKEN, header_timeout=1.0))
    writers = []
    try:
        started = time.monotonic()
        raws = [await open_raw(running, b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ") for _ in range(20)]
        writers = [w for _, w in raws]

        async def trickle() -> None:  # one byte every 0.2 s: never a whole header
            for _ in range(20):
                for writer in writers:
                    if not writer.is_closing():
                        writer.write(b"a")
                await asyncio.sleep(0.2)

        trickling = asyncio.create_task(trickle())
        # Meanwhile the operator connects as usual.
        operator = await TestClient.open(f"{running.ws_url}?token={TOKEN}")
        assert (await operator.hello())["role"] == "operator"
        closed = await asyncio.gather(*(closed_by_relay(r, 3.0 + LOAD_SLACK) for r, _ in raws))
        elapsed = time.monotonic() - started
        trickling.cancel()
        assert all(closed), f"{closed.count(False)} slow connections still open after {elapsed:.1f} s"
        assert elapsed < 1.0 + 1.0 + LOAD_SLACK, elapsed  # the timeout, the sweep period and the load's slack
        await answers_ping(operator)  # the admitted operator was left alone
        await operator.close()
    finally:
        for writer in writers:
            writer.close()
        await running.runner.cleanup()


async def test_a_flood_of_half_open_connections_evicts_itself_not_the_operator(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config, options=Options(token=TOKEN, max_unadmitted=16))
    raws = []
    try:
        operator = await TestClient.open(f"{running.ws_url}?token={TOKEN}")
        await operator.hello()
        raws = [await open_raw(running) for _ in range(60)]  # connect, send nothing
        await asyncio.sleep(0.3)
        still_open = [not await closed_by_relay(r, 0.05) for r, _ in raws]
        assert sum(still_open) <= 16, f"{sum(still_open)} half-open connections kept"
        assert still_open[-16:] == [True] * 16  # the newest are kept: a newcomer is never the one turned away
        # A second operator tab connects in the middle of the flood, and the first is still there.
        second = await TestClient.open(f"{running.ws_url}?token={TOKEN}")
        assert (await second.hello())["role"] == "operator"
        await answers_ping(operator)
        for client in (operator, second):
            await client.close()
    finally:
        for _, writer in raws:
            writer.close()
        await running.runner.cleanup()


async def test_accept_failures_are_logged_once_per_interval(caplog: pytest.LogCaptureFixture) -> None:
    guard = ConnectionGuard(max_connections=100)

    class Server:
        def connection_made(self, handler: object, transport: object) -> None: ...

        def connection_lost(self, handler: object, exc: BaseException | None) -> None: ...

    guard.attach(Server())
    loop = asyncio.get_running_loop()
    with caplog.at_level(logging.ERROR, logger="relay.net.guard"):
        for _ in range(1000):
            loop.call_exception_handler({"message": ACCEPT_FAILURE, "exception": OSError(24, "Too many open files")})
    guard.stop()
    loop.set_exception_handler(None)
    lines = [r for r in caplog.records if r.name == "relay.net.guard"]
    assert len(lines) == 1 and "1 failures so far" in lines[0].getMessage()
    assert guard.counts["accept_failures"] == 1000


async def test_a_relay_short_of_descriptors_still_lets_the_operator_in(tmp_path: Path) -> None:
    # The relay runs with 256 descriptors at most; 400 connections are thrown at it.
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < 1024:
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 4096), hard))

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_NOFILE, (256, 256))

    relay, base = await relay_process(
        "--token",
        TOKEN,
        "--allow-weak-token",
        "--audit-log",
        str(tmp_path / "audit.jsonl"),
        stderr=asyncio.subprocess.PIPE,
        preexec_fn=limit,
    )
    writers = []
    try:
        assert relay.stderr is not None
        host, port = base.removeprefix("http://").split(":")
        for _ in range(400):
            _, writer = await asyncio.open_connection(host, int(port))
            writers.append(writer)
        operator = await TestClient.open(base.replace("http", "ws") + f"/ws?token={TOKEN}")
        assert (await operator.hello())["role"] == "operator"
        async with aiohttp.ClientSession() as http, http.get(base + "/healthz") as response:
            assert response.status == 200
        await operator.close()
        for writer in writers:
            writer.close()
        relay.terminate()
        assert await asyncio.wait_for(relay.wait(), 10) == 0
        log = (await relay.stderr.read()).decode()
        assert log.count("Traceback") == 0, log[-3000:]
        assert len(log.splitlines()) < 40, log[-3000:]
    finally:
        if relay.returncode is None:
            relay.kill()
            await relay.wait()


@pytest.mark.parametrize(
    ("host", "status"),
    [
        ("evil.example:{port}", 403),  # DNS rebinding: the attacker's name, re-pointed at 127.0.0.1
        ("127.0.0.1:{port}", 200),
        ("localhost:{port}", 200),
        ("[::1]:{port}", 200),
        ("relay.lab.example:{port}", 200),  # --allow-host
    ],
)
async def test_the_host_header_must_name_this_relay(fleet_config: FleetConfig, host: str, status: int) -> None:
    running = await start_relay(fleet_config, options=Options(token=TOKEN, allowed_hosts=("relay.lab.example",)))
    try:
        port = running.url.rsplit(":", 1)[1]
        header = host.format(port=port)
        origin = f"http://{header}"
        async with aiohttp.ClientSession() as http:
            async with http.get(running.url + "/healthz", headers={"Host": header}) as response:
                assert response.status == status, await response.text()
            ws_headers = {"Host": header, "Origin": origin}
            if status == 403:
                with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                    await http.ws_connect(f"{running.ws_url}?token={TOKEN}", headers=ws_headers)
                assert refused.value.status == 403
            else:
                ws = await http.ws_connect(f"{running.ws_url}?token={TOKEN}", headers=ws_headers)
                await ws.close()
    finally:
        await running.runner.cleanup()
