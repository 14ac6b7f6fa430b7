"""A Zenoh router on loopback for the zenoh backend's tests, the fleet they share and the relay on it."""

from __future__ import annotations

import asyncio
import contextlib
import sys
import time
from collections.abc import AsyncIterator
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.cli.options import Options, ZenohOptions  # noqa: E402
from relay.config import FleetConfig, parse_config  # noqa: E402
from tests.conftest import ROOT, RunningRelay, start_relay  # noqa: E402
from tests.zenoh_robots import (  # noqa: E402
    STORE,
    Received,
    attachment,
    free_port,
    router_config,
)

FLEET = """
safety: {deadman_timeout: 0.5, offline_after: 2.0}
zenoh: {domain_id: 0}
robots:
  - name: alpha
    pose: odom
    limits: {linear: 0.5, angular: 1.0}
    scan: null
    cameras:
      - {name: front, lens: {model: equidistant, fov: 180}, width: 64, height: 48}
      - {name: jpeg, compressed: true, topic: camera/jpeg/compressed}
    sensors:
      - {name: gas, type: std_msgs/Float32, unit: ppm, warn_above: 400}
  - name: beta
    pose: {source: tf, base_frame: base_link}
    limits: {linear: 0.3, angular: 0.8}
    scan: null
"""


ODOM = ("alpha/odom", "nav_msgs::msg::dds_::Odometry_", "nav_msgs/msg/Odometry")


class Router:
    """A Zenoh router session on 127.0.0.1:port, which is also the robots' side."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.endpoint = f"tcp/127.0.0.1:{port}"
        self.session: Any = None

    async def open(self) -> None:
        self.session = await asyncio.to_thread(zenoh.open, router_config(self.port))

    async def close(self) -> None:
        if self.session is not None:
            await asyncio.to_thread(self.session.close)
            self.session = None

    def put(self, topic_key: str, payload: bytes, sequence: int = 1) -> None:
        self.session.put(topic_key, payload, attachment=attachment(sequence))

    def listen(self, selector: str) -> Received:
        received = Received()
        self.session.declare_subscriber(selector, received)
        return received


def fleet() -> FleetConfig:
    return parse_config(FLEET, "fleet.yaml")


async def zenoh_relay(router: Router, relay_id: str = "A") -> RunningRelay:
    options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(router.endpoint,), relay_id=relay_id))
    return await start_relay(fleet(), options=options)


def decode(data: bytes, type_name: str) -> Any:
    return STORE.deserialize_cdr(data, type_name)


async def until(condition: Any, timeout: float, what: str) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        await asyncio.sleep(0.05)
    raise AssertionError(f"{what}: not within {timeout} s")


@contextlib.asynccontextmanager
async def demo_fleet_over_zenoh() -> AsyncIterator[str]:
    """tools/fake_fleet_zenoh.py with the demo's robots.yaml, its own router on a free loopback port, once it says it
    listens; the endpoint a relay connects to. Stopped on the way out."""
    port = free_port()
    fleet = await asyncio.create_subprocess_exec(
        sys.executable, str(ROOT / "tools" / "fake_fleet_zenoh.py"), "--listen", f"tcp/127.0.0.1:{port}",
        "--log-level", "warning", stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    assert fleet.stdout is not None
    try:
        line = await asyncio.wait_for(fleet.stdout.readline(), 30)
        assert b"a Zenoh router on" in line, line
        yield f"tcp/127.0.0.1:{port}"
    finally:
        fleet.terminate()
        await asyncio.wait_for(fleet.wait(), 10)
