"""Faults and slow peers: a client killed mid-teleop (20 of 20 trials) and a client that stops reading.

The relay terminated while a robot drives is in tests/test_ros_backend.py (over DDS); longer runs with
figures are in bench/ and docs/reliability.md.
"""

from __future__ import annotations

import asyncio
import base64
import os
import signal
import socket
import subprocess
import sys
import time

from relay.config import FleetConfig
from tests.conftest import LOAD_SLACK, ROOT, RunningRelay, start_relay
from tests.helpers.spy import CommandSpy
from tests.wsclient import TestClient

DRIVER = """
import sys, time, json
from websockets.sync.client import connect
ws = connect(sys.argv[1])
ws.recv()
print("driving", flush=True)
while True:
    ws.send(json.dumps({"identifier": "robot2/cmd_vel", "linear": 0.4, "angular": 0.2}))
    time.sleep(0.05)
"""


async def test_client_killed_mid_teleop_stops_the_robot_every_time(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config)
    spy = CommandSpy(running.relay.backend)  # type: ignore[arg-type]
    delays: list[float] = []
    try:
        for _ in range(20):
            # Forking this big test process takes a while: in a thread, not on the loop under test.
            driver = await asyncio.to_thread(
                subprocess.Popen, [sys.executable, "-c", DRIVER, running.ws_url], stdout=subprocess.PIPE, cwd=ROOT
            )
            assert driver.stdout is not None
            assert (await asyncio.to_thread(driver.stdout.readline)).strip() == b"driving"
            await asyncio.sleep(0.3)
            assert any(n == "send_velocity" and a[1] == 0.4 for _, n, a in spy.calls), "never drove"
            killed = time.monotonic()
            driver.send_signal(signal.SIGKILL)
            await asyncio.to_thread(driver.wait)
            driver.stdout.close()
            deadline = killed + 3.0
            stop = None
            while stop is None and time.monotonic() < deadline:
                await asyncio.sleep(0.02)
                stop = next(
                    (t for t, n, a in spy.calls if t >= killed and n == "send_velocity" and a == ("robot2", 0.0, 0.0)),
                    None,
                )
            assert stop is not None, "no zero velocity after the kill"
            delays.append(stop - killed)
            spy.calls.clear()
        # Killed clients vanish from the kernel at once (RST) or after the deadman's 0.5 s of silence.
        assert max(delays) <= 0.6 + LOAD_SLACK, delays
    finally:
        await running.runner.cleanup()


class StalledClient:
    """Completes the WebSocket handshake, then never reads a byte: the kernel buffers fill and stay full."""

    def __init__(self, url: str) -> None:
        host, port_path = url.removeprefix("ws://").split(":", 1)
        port = int(port_path.split("/")[0])
        self.sock = socket.socket()
        # A tiny receive window, set before connecting so that it is what the relay's kernel sees: the
        # relay's socket then fills after a few frames instead of megabytes.
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        self.sock.connect((host, port))
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(
            (
                f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
            ).encode()
        )
        self.sock.settimeout(5)
        assert b"101" in self.sock.recv(12)

    def send_text(self, text: str) -> None:
        """One masked text frame (clients must mask), written straight to the socket."""
        payload = text.encode()
        mask = os.urandom(4)
        assert len(payload) < 126
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(bytes([0x81, 0x80 | len(payload)]) + mask + masked)

    def close(self) -> None:
        self.sock.close()


async def test_a_client_that_stops_reading_costs_bounded_memory(relay_server: RunningRelay) -> None:
    relay = relay_server.relay
    stalled = await asyncio.to_thread(StalledClient, relay_server.ws_url)
    clients: list[TestClient] = []
    # Closed however the test ends: a stalled socket left open would hold the relay's shutdown (and the suite).
    try:
        # It asks for the camera stream, then reads nothing: its socket buffers fill, then its lanes.
        stalled.send_text('{"identifier":"robot1/stream","id":"s","camera":"front","fps":15}')
        clients.extend([await TestClient.open(relay_server.ws_url) for _ in range(5)])
        for client in clients:
            await client.hello()
            await client.request({"identifier": "robot1/stream", "camera": "front", "fps": 5})
        channel = next(
            c.channel for c in relay._clients.values() if c.channel.streams.get("robot1/camera/front", (0,))[0] != 5
        )
        started = time.monotonic()
        counters = relay.hub.counters

        def camera_frames(client: TestClient) -> int:
            return sum(1 for _, h, _ in client.frames if h["identifier"] == "robot1/camera/front")

        # Until it has cost something and the others have had a few pictures of their 5 fps stream (on a loaded
        # machine the stalled one may be noticed within the first picture's time).
        while time.monotonic() - started < 30 and not (  # noqa: ASYNC110
            counters.frames_dropped and counters.state_coalesced and all(camera_frames(c) >= 3 for c in clients)
        ):
            await asyncio.sleep(0.5)
        elapsed = time.monotonic() - started
        # It is stalled (values were replaced and frames dropped for it), and its lanes hold at most one value
        # per state key and two frames however long it lasts.
        assert counters.frames_dropped > 0 and counters.state_coalesced > 0
        # Per robot: pose, three sensors, status, laser scan; and an arm's joints (robot3's, with the shared data).
        state_keys = 3 * (1 + 3 + 1 + 1) + len(relay.arms.loaded.arms)
        assert channel.queued <= state_keys + 2
        # Meanwhile the others keep receiving the 30 Hz poses and their stream.
        for client in clients:
            poses = [t for t, m in client.messages if m["identifier"] == "robot2/pose" and t >= started]
            # 30 Hz on a quiet machine; fewer when the relay waits for a CPU, but they keep coming
            assert len(poses) / elapsed >= 10, len(poses) / elapsed
            assert camera_frames(client) >= 3
    finally:
        for client in clients:
            await client.close()
        stalled.close()
