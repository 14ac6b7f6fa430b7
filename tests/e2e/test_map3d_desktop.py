"""The live 3D map on the desktop (issue #33): three sim robots drive into their rooms, their depth cameras' clouds
are fused by the relay and streamed, and the page draws the voxels; the menu's `Twin` hides the glTF twin so that the
map alone shows what the robots saw, and `3D map` hides the map. The screenshot is docs/client.md's."""

from __future__ import annotations

import asyncio
import math
import time

from tests.conftest import RunningRelay
from tests.helpers.browser import SOFTWARE_GL, Client, OpenClient, wait_until
from tests.helpers.map3d import goal_at_relay, map_spots, mapping_relay


async def test_the_map_is_drawn_and_the_twin_switches_off(open_client: OpenClient) -> None:
    async with mapping_relay() as running:
        fusion = running.relay.fusion
        assert fusion is not None
        client = await open_client(f"{running.url}/?{SOFTWARE_GL}", "map3d", 1280, 760)
        await wait_until(lambda: fusion.counters.integrated >= 9, 60, "9 clouds fused")
        # The page holds the map the relay has, drawn: thousands of voxels, one instanced mesh.
        await client.wait("s.voxels.drawn > 1000 && s.voxels.visible && s.voxels.twin", 30)
        await client.page.keyboard.press("t")  # the top view: every room's walls at once
        await client.wait("s.view.mode === 'top'", 5)
        await client.drawn(2)
        await client.shot("01-map-with-twin")
        await client.page.click('#menu button[data-button="opt:twin"]')
        await client.wait("!s.voxels.twin", 5)
        await client.drawn(2)
        await client.shot("02-map-alone", "desktop-3d-map.png")
        await goals_are_set_on_the_map(client, running)
        # Later changes come too: robot1 turns on the spot (the robots have stopped in their rooms, and a map seen
        # from where it was seen does not change), and the page's version follows the relay's.
        version = (await client.state())["voxels"]["version"]
        await running.relay.backend.send_velocity("robot1", 0.0, 1.0)
        await client.wait("s.voxels.version > arg", 20, version)
        await client.page.click('#menu button[data-button="opt:map3d"]')
        await client.wait("!s.voxels.visible", 5)
        assert client.errors == [], client.errors


async def over_the_map(client: Client, spot: tuple[float, float, float], voxel: float) -> tuple[float, float] | None:
    """The page point over a map point, once the pointer there meets the map at it and a press would send a goal
    (the cursor's verdict): the view may still be framing itself after a panel opened (a loaded run computed the point,
    the view moved, and the click met unseen floor). None when it never does."""
    for _ in range(3):
        x, y = await client.page.evaluate("([x, y, z]) => window.__xrRelay.mapToPage(x, y, z)", list(spot))
        free = (await client.state())["view"]["free"]  # the window's part no panel covers
        if not (free["left"] + 10 < x < free["right"] - 10 and free["top"] + 10 < y < free["bottom"] - 10):
            return None
        await client.page.mouse.move(x, y)
        await client.drawn(2)
        goal = (await client.state())["goal"]
        hover, verdict = goal["hover"], goal["verdict"]
        met = hover is not None and math.dist((hover["x"], hover["y"]), spot[:2]) < 2 * voxel
        if met and (verdict is None or verdict["kind"] == "goal"):
            return x, y
    return None


async def goals_are_set_on_the_map(client: Client, running: RunningRelay) -> None:
    """With the twin hidden, the goal pointer meets the map (issue #33: goals set on it): a click on floor the robots
    saw sends the goal there; a click on the facility's floor where the map has nothing sends none."""
    fusion = running.relay.fusion
    assert fusion is not None
    occupied = await fusion.run(lambda voxels: voxels.occupied())
    patches, unseen = await asyncio.to_thread(map_spots, running, occupied, fusion.voxel)
    page = client.page
    await page.click('#menu button[data-button="robot:robot1"]')
    await page.click('#menu button[data-button="tool:goal"]')
    await client.wait("s.menu.tool === 'goal' && s.menu.selected === 'robot1'", 10)
    before = (await client.state())["goal"]["sent"]
    px, py = await page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", list(unseen))
    await page.mouse.click(px, py)
    await client.drawn(2)
    assert (await client.state())["goal"]["sent"] == before, f"a goal was sent at {unseen}, where the map has nothing"
    top = fusion.voxel  # the floor voxels' top face
    # A patch of seen floor where the cursor says a press sends a goal: the farthest from the robots first (seen from
    # far above, a robot's label covers floor a metre or two away, and a press there selects the robot instead).
    robots = list(running.relay.fleet.positions(time.monotonic()).values())
    patches.sort(key=lambda p: -min(math.dist(p, r) for r in robots))
    for seen in patches[:10]:
        if (at := await over_the_map(client, (*seen, top), fusion.voxel)) is not None:
            break
    assert at is not None, f"the pointer met none of the map's floor patches {patches[:10]}: {await client.state()}"
    x, y = at
    sent = await goal_at_relay(client, running, "robot1", lambda: page.mouse.click(x, y))
    assert sent is not None and math.dist((sent["x"], sent["y"]), seen) < 2 * fusion.voxel, (sent, seen)
