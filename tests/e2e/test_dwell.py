"""Head-gaze dwell (issue #17) in Chromium with IWER's emulated Quest 3: with the menu's **Gaze press** option on,
resting the head's gaze on a menu button for the dwell time presses it once, the reticle filling meanwhile; with it
off, the same gaze presses nothing (accessibility, opt-in). IWER turns the headset; the controllers point away."""

from __future__ import annotations

import asyncio
import time
from typing import Any

from .conftest import Client, OpenClient, Station
from .test_client_vr import enter_vr
from .xr_helpers import aim, press_menu_button, set_menu

#: gestures.js's DWELL_MS: how long a gaze rests before it presses.
DWELL_MS = 1500

#: Turn the emulated headset so that its view's centre is on a scene point (the rig's yaw undone).
LOOK = """
async (target) => {
  const THREE = await import('three');
  const s = window.__xrRelay.state;
  const eye = new THREE.Vector3(...s.eye);
  const rig = new THREE.Quaternion(...s.rig.quaternion);
  const local = new THREE.Vector3(...target).sub(eye).normalize().applyQuaternion(rig.clone().invert());
  const q = new THREE.Quaternion().setFromUnitVectors(new THREE.Vector3(0, 0, -1), local);
  window.__iwer.quaternion.set(q.x, q.y, q.z, q.w);
}
"""


def active(s: dict[str, Any], button: str) -> bool:
    return any(b["id"] == button and b["active"] for b in s["menu"]["buttons"])


async def look_at_button(client: Client, button: str) -> None:
    s = await client.state()
    await client.page.evaluate(LOOK, s["menu"]["centres"][button])


async def test_a_gaze_resting_on_a_menu_button_presses_it_only_when_gaze_press_is_on(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    await set_menu(client, True)
    s = await client.state()
    assert not active(s, "opt:dwell") and active(s, "opt:scans"), "gaze press is off by default; scans on"
    # Off: resting on Scans presses nothing.
    for hand in ("left", "right"):
        await aim(client, hand, [0.0, -5.0, 0.0])  # the rays on the floor, away from the menu
    await look_at_button(client, "opt:scans")
    await client.wait("s.gaze.id === null", 10)
    await asyncio.sleep(2.5)
    s = await client.state()
    assert active(s, "opt:scans") and s["gaze"]["fired"] == 0, s["gaze"]
    # On (pressed with the controller, the gaze down at the floor, off the menu): resting on Scans presses it once,
    # after the dwell, not at a glance.
    s = await client.state()
    await client.page.evaluate(LOOK, [s["eye"][0], 0.0, s["eye"][2] - 1.0])
    await press_menu_button(client, "opt:dwell")
    await client.wait("s.menu.buttons.some((b) => b.id === 'opt:dwell' && b.active)", 10)
    for hand in ("left", "right"):
        await aim(client, hand, [0.0, -5.0, 0.0])
    await client.wait("s.gaze.id === null", 10)
    fired = (await client.state())["gaze"]["fired"]
    assert fired == 0 and active(await client.state(), "opt:scans")
    looked = time.monotonic()
    await look_at_button(client, "opt:scans")
    await client.wait("s.gaze.id === 'opt:scans'", 10)
    await client.shot("dwell-resting")
    s = await client.wait("s.gaze.fired === arg && s", 10, fired + 1)
    assert time.monotonic() - looked >= DWELL_MS / 1000, "pressed by a dwell, not at a glance"
    assert not active(s, "opt:scans"), "the dwell pressed Scans"
    await asyncio.sleep(2.5)
    s = await client.state()
    assert s["gaze"]["fired"] == fired + 1 and not active(s, "opt:scans"), "once per rest, not again while it stays"
    await set_menu(client, False)
