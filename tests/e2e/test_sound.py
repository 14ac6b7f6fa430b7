"""Sound (issue #17) in Chromium: the earcons' audio graph rendered offline (an OfflineAudioContext, no speakers)
and checked for where it was panned; and on a live page, the estop's earcon counted as the page played it, after the
first gesture started its AudioContext."""

from __future__ import annotations

import asyncio
import warnings
from typing import Any

from tests.helpers.browser import SOFTWARE_GL, Client, OpenClient, Station, confirm_reset, wait_until

#: Renders one earcon with the listener at head height looking north (-z in the scene) and the source 3 m to the
#: given side, half a metre ahead; returns each channel's energy.
RENDER = """
async ([kind, x]) => {
  const { Soundscape } = await import('/src/view/sound.js');
  const ctx = new OfflineAudioContext(2, Math.round(44100 * 0.7), 44100);
  const scape = new Soundscape(ctx);
  scape.listen({ x: 0, y: 1.6, z: 0 }, { x: 0, y: 0, z: -1 }, { x: 0, y: 1, z: 0 });
  scape.play(kind, x === null ? null : { x, y: 1.6, z: -0.5 });
  const buffer = await ctx.startRendering();
  const energy = (c) => buffer.getChannelData(c).reduce((sum, v) => sum + v * v, 0);
  return [energy(0), energy(1)];
}
"""


#: An offline rendering takes 0.02-0.5 s (the first loads Chromium's HRTF database), 2 s on a loaded machine; one
#: that hung never finished in the 60 s this bound once was. With one Chromium per worker the first rendering on the
#: first page hung in 2 of 4 browser runs (none in the 2 before), and the new page's passed each time.
RENDER_BOUND_S = 20.0


async def render(open_client: OpenClient, url: str, kind: str, x: float | None, pages: list[Client]) -> list[float]:
    """One earcon rendered offline; a rendering that never finishes is tried once more in a new page.

    Three CI runs lost a worker in this test (pytest-timeout ends the process after 300 s, without a word in the
    run's output); the one call here without a timeout of its own is the offline rendering, which is Chromium's,
    not the station's (its graph is the one measured): one that does not finish in 60 s is said, and tried again
    once in a new page."""
    for attempt in (1, 2):
        try:
            result: list[float] = await asyncio.wait_for(pages[-1].page.evaluate(RENDER, [kind, x]), RENDER_BOUND_S)
            return result
        except TimeoutError:
            if attempt == 2:
                raise AssertionError(f"Chromium's offline rendering of {kind} at {x} hung twice") from None
            warnings.warn(
                f"Chromium's offline rendering of {kind} at {x} hung for {RENDER_BOUND_S} s: a new page", stacklevel=2
            )
            pages.append(await open_client(url, f"sound-offline-{len(pages)}"))
    raise AssertionError("unreachable")


async def test_an_earcon_is_heard_from_the_robots_side(station: Station, open_client: OpenClient) -> None:
    url = f"{station.url}/?{SOFTWARE_GL}"
    pages = [await open_client(url, "sound-offline")]
    energies: dict[str, Any] = {}
    for kind in ("warning", "estop", "goal_refused"):
        right = await render(open_client, url, kind, 3.0, pages)
        left = await render(open_client, url, kind, -3.0, pages)
        everywhere = await render(open_client, url, kind, None, pages)
        energies[kind] = {"right": right, "left": left, "everywhere": everywhere}
        assert min(right + left) > 1.0, f"{kind}: the earcon makes a sound ({right}, {left})"
        # HRTF: a source on the right is louder in the right ear, and the other way round. The head shadows high
        # tones more than low ones: the warning (660-880 Hz, where its place matters most) by far more than the
        # estop's low horn (220 Hz, measured 2.0x), which plays unpanned for a fleet-wide stop anyway.
        ratio = 2.5 if kind == "warning" else 1.5
        assert right[1] > ratio * right[0], (kind, right)
        assert left[0] > ratio * left[1], (kind, left)
        assert abs(everywhere[0] - everywhere[1]) < 0.01 * everywhere[0], "unpanned: both ears alike"
    assert [error for client in pages for error in client.errors] == []


async def test_the_page_plays_the_estop_earcon_after_the_first_gesture_and_mutes_by_key(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "sound-live")
    page = client.page
    assert (await client.state())["sound"]["started"] is False, "no sound before a gesture"
    await page.click('#menu button[data-button="robot:robot1"]')
    await client.wait("s.sound.started", 5)
    await page.keyboard.press("m")
    await client.wait("s.sound.muted", 5)
    await page.keyboard.press("m")
    await client.wait("!s.sound.muted", 5)
    # The menu's Mute (the same button in VR) mutes, and the key unmutes it: one state.
    await page.click('#menu button[data-button="opt:mute"]')
    await client.wait("s.sound.muted && s.menu.buttons.some((b) => b.id === 'opt:mute' && b.active)", 5)
    await page.keyboard.press("m")
    await client.wait("!s.sound.muted && s.menu.buttons.some((b) => b.id === 'opt:mute' && !b.active)", 5)
    # The menu's Volume − and + (in VR too) and the header's slider are one volume.
    await page.click('#menu button[data-button="opt:volume-"]')
    await client.wait("s.sound.volume === 0.4", 5)
    assert await page.input_value("#sound-volume") == "40"
    await page.fill("#sound-volume", "80")
    await client.wait("s.menu.buttons.some((b) => b.id === 'opt:volume-' && b.label === 'Volume − (80 %)')", 5)
    await page.click('#menu button[data-button="opt:volume+"]')
    await client.wait("s.sound.volume === 1", 5)
    # The hazard ticks: the menu's button (in VR too) and G are one switch.
    await page.click('#menu button[data-button="opt:ticks"]')
    await client.wait("s.sound.geiger && s.menu.buttons.some((b) => b.id === 'opt:ticks' && b.active)", 5)
    await page.keyboard.press("g")
    await client.wait("!s.sound.geiger && s.menu.buttons.some((b) => b.id === 'opt:ticks' && !b.active)", 5)
    await page.click('#menu button[data-button="estop"]')
    await client.wait("s.sound.played.estop === 1", 5)
    await wait_until(lambda: all(station.status(r)["estopped"] for r in ("robot1", "robot2", "robot3")), 5, "latched")
    await confirm_reset(page)
    await wait_until(lambda: not any(station.status(r)["estopped"] for r in ("robot1", "robot2", "robot3")), 5, "reset")
    s = await client.state()
    assert s["sound"]["played"] == {"estop": 1}, s["sound"]
    assert client.errors == [], client.errors
