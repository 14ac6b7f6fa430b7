"""Haptics (issue #17) on IWER's own actuators: the page pulses each controller's `gamepad.hapticActuators[0]`, which
IWER implements (it keeps the last pulse). A recorder wraps those actuators (the calls still reach IWER) so the test
sees every pulse, its strength, length and spacing. While the operator drives robot2 another operator takes it over
by force: two pulses on each controller; the operator's own E-STOP (the X button): three strong ones. Hovering menu
buttons ticks (a quarter strength, 15 ms) and never counts as either."""

from __future__ import annotations

import time
from typing import Any

from tests.helpers.browser import OpenClient, Station, wait_until
from tests.helpers.xr import button, enter_vr, stick, teleop_on
from tests.wsclient import TestClient

#: Wrap each emulated controller's actuator; pulses land in window.__pulses as {hand, value, ms, t}.
RECORD = """
async () => {
  const { P_GAMEPAD } = await import('iwer');
  window.__pulses = [];
  window.__lastPulse = (hand) => {
    const a = window.__iwer.controllers[hand].inputSource.gamepad.hapticActuators[0];
    return a[P_GAMEPAD].lastPulse;
  };
  for (const hand of ['left', 'right']) {
    const actuator = window.__iwer.controllers[hand].inputSource.gamepad.hapticActuators[0];
    const pulse = actuator.pulse.bind(actuator);
    actuator.pulse = (value, ms) => {
      window.__pulses.push({ hand, value, ms, t: performance.now() });
      return pulse(value, ms);
    };
  }
}
"""


async def pulses(client: Any, value: float) -> list[dict[str, Any]]:
    found: list[dict[str, Any]] = await client.page.evaluate(
        "(v) => window.__pulses.filter((p) => Math.abs(p.value - v) < 1e-6)", value
    )
    return found


async def test_a_lost_lease_and_an_estop_pulse_both_controllers_on_iwers_actuators(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    await client.page.evaluate(RECORD)
    await teleop_on(client, "robot2")
    me = (await client.state())["clientId"]
    await stick(client, "right", 0.0, -0.5)
    await wait_until(lambda: station.status("robot2")["controller"] == me, 10, "robot2 driven by this operator")
    await client.wait("s.robots.robot2.controller === s.clientId", 10)  # and the page knows it
    assert await pulses(client, 0.8) == [], "no lease pulse before the lease is lost"
    # Another operator takes robot2 over while this one drives.
    other = await TestClient.open(station.running.ws_url)
    try:
        await other.hello()
        taken = time.monotonic()
        assert (await other.request({"identifier": "robot2/lease", "force": True}))["identifier"] == "ack"
        await client.wait(
            "window.__pulses.filter((p) => p.value === 0.8).length >= 4", 10
        )  # two pulses on each controller
        assert time.monotonic() - taken < 5
    finally:
        await other.close()
    await stick(client, "right", 0.0, 0.0)
    lost = await pulses(client, 0.8)
    assert sorted(p["hand"] for p in lost) == ["left", "left", "right", "right"], lost
    assert all(p["ms"] == 80 for p in lost)
    right = [p["t"] for p in lost if p["hand"] == "right"]
    assert right[1] - right[0] >= 80 + 50, "two distinct pulses, not one merged buzz"
    # The operator's own E-STOP: three strong pulses on each controller.
    await button(client, "left", "x-button", 1)
    await client.wait("window.__pulses.filter((p) => p.value === 1).length >= 6", 10)
    await button(client, "left", "x-button", 0)
    strong = await pulses(client, 1.0)
    assert sorted(p["hand"] for p in strong) == ["left"] * 3 + ["right"] * 3, strong
    assert all(p["ms"] == 120 for p in strong)
    last = await client.page.evaluate("window.__lastPulse('right')")
    assert last["value"] == 1 and last["duration"] == 120, "IWER's actuator got it"
    await wait_until(lambda: station.status("robot2")["estopped"], 5, "latched")
    ticks = await pulses(client, 0.25)
    assert all(p["ms"] == 15 for p in ticks), "menu ticks stay ticks"
    assert client.errors == [], client.errors
