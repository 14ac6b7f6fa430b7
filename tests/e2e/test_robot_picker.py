"""Fleets of 20-100 (issue #31): with 20 robots the desktop menu's robot buttons had shrunk to `ro` and the VR menu's
to unlabelled slivers. On the desktop a fleet larger than a row of buttons gets a picker (the selected robot's name,
a search box, a list of every robot with its status); in VR the robot row is paged, full names, `‹` / `›`. These
check what an operator notices: every robot can be found and selected by name, names are whole, the E-STOP stays in
reach and its keys keep stopping the fleet while a search is typed."""

from __future__ import annotations

import asyncio
import base64
import itertools
import math
import shutil
from collections.abc import AsyncIterator, Awaitable, Callable

from bench.bench_client_frame import fleet_yaml
from relay.config import parse_config
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.browser import (
    ARTIFACTS,
    DOC_IMAGES,
    SOFTWARE_GL,
    UPDATE_DOC_IMAGES,
    Client,
    OpenClient,
    covered,
    fixture,
)
from tests.helpers.xr import enter_vr, press_menu_button, set_menu

StartFleet = Callable[[int], Awaitable[RunningRelay]]
ESTOP = '#menu button[data-button="estop"]'
SEARCH = "#menu .picker .picker-search"


@fixture
async def fleet_of() -> AsyncIterator[StartFleet]:
    """A relay with N sim robots, robot1..robotN (the benchmark's fleet), stopped after the test."""
    running: list[RunningRelay] = []

    async def start(count: int) -> RunningRelay:
        text = await asyncio.to_thread(fleet_yaml, count)
        # 10 poses a second (the benchmark's 30 would load the test's own event loop, which runs the relay too).
        text = text.replace("pose_rate: 30", "pose_rate: 10")
        config = await asyncio.to_thread(parse_config, text, f"robots-{count}.yaml", ROOT)
        relay = await start_relay(config)
        running.append(relay)
        return relay

    yield start
    for relay in running:
        await relay.runner.cleanup()


def save_png(data: str, name: str, doc_name: str) -> None:
    """A canvas's PNG (base64) as an artefact, and as the docs' image when they are updated."""
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / name).write_bytes(base64.b64decode(data))
    if UPDATE_DOC_IMAGES:
        shutil.copyfile(ARTIFACTS / name, DOC_IMAGES / doc_name)


async def listed(client: Client) -> list[str]:
    """The names the open picker lists, top to bottom."""
    names: list[str] = await client.page.eval_on_selector_all(
        "#menu .picker-list li button[data-robot]", "(bs) => bs.map((b) => b.dataset.robot)"
    )
    return names


async def test_twenty_robots_are_picked_by_name_on_the_desktop(fleet_of: StartFleet, open_client: OpenClient) -> None:
    relay = await fleet_of(20)
    client = await open_client(f"{relay.url}/?{SOFTWARE_GL}", "picker-20", 1280, 800)
    page = client.page
    await client.wait("Object.keys(s.robots).length === 20")
    await client.drawn(1)
    view = (await client.state())["view"]["mode"]
    assert view != "top"

    # The robot row is the picker: no row of 20 shrunken buttons; the E-STOP is in reach.
    await page.wait_for_selector("#menu .picker .picker-current")
    assert await page.locator('#menu button[data-button^="robot:"]').count() == 0
    assert await page.inner_text("#menu .picker .picker-current") == "No robot ▾"
    assert await covered(page, ESTOP) == []

    # Clicking the search box opens the list of every robot, in natural order, each name whole.
    await page.click(SEARCH)
    await page.wait_for_selector("#menu .picker-list", state="visible")
    assert await listed(client) == [f"robot{i}" for i in range(1, 21)]
    cut = await page.eval_on_selector_all(
        "#menu .picker-list .name",
        """(names) => names.filter((n) => n.scrollWidth > n.clientWidth || n.parentElement.scrollWidth >
          n.parentElement.clientWidth || n.textContent !== n.parentElement.dataset.robot).map((n) => n.textContent)""",
    )
    assert cut == []
    statuses = await page.eval_on_selector_all("#menu .picker-list .state", "(s) => s.map((e) => e.textContent)")
    assert set(statuses) <= {"idle", "navigating", "teleop"}, statuses
    assert await covered(page, ESTOP) == [], "the open list covers the E-STOP"

    # Typed on the keyboard, a name's letters fly nothing and stop nothing (T is Top-down, Space and Esc E-STOP).
    await page.keyboard.type("robot17")
    await client.wait("s.estop.latched.length === 0")
    assert await listed(client) == ["robot17"]
    await client.shot("01-picker")
    await page.keyboard.press("Enter")
    s = await client.wait("s.menu.selected === 'robot17' && s")
    assert s["view"]["mode"] == view and s["estop"]["latched"] == []
    assert await page.inner_text("#menu .picker .picker-current") == "robot17 ▾"
    assert await page.locator("#menu .picker-list").is_hidden()

    # Every robot is found by its number and selected with Enter.
    for i in range(1, 21):
        await page.fill(SEARCH, str(i))
        assert (await listed(client))[0] == f"robot{i}"
        await page.press(SEARCH, "Enter")
        await client.wait("s.menu.selected === arg", 10, f"robot{i}")

    # A click on an entry selects it too; the list says which robot is selected.
    await page.click(SEARCH)
    await page.click('#menu .picker-list button[data-robot="robot9"]')
    await client.wait("s.menu.selected === 'robot9'")
    await page.click(SEARCH)
    assert await page.get_attribute('#menu .picker-list button[data-robot="robot9"]', "aria-selected") == "true"
    await client.shot("02-list")

    # Stopped, robot9 heads the list sorted by status, marked E-STOPPED.
    await page.click('#menu button[data-button="estop:robot"]')
    await client.wait("s.estop.latched.includes('robot9')")
    await page.click(SEARCH)
    await page.click('#menu .picker-sort button[data-sort="status"]')
    await page.wait_for_function(
        "() => document.querySelector('#menu .picker-list li button[data-robot]')?.dataset.robot === 'robot9'"
    )
    assert await page.inner_text('#menu .picker-list button[data-robot="robot9"] .state') == "E-STOPPED"
    assert (await listed(client))[1:] == [f"robot{i}" for i in range(1, 21) if i != 9]
    assert await covered(page, '#menu .picker-list button[data-robot="robot9"]') == [], "robot9 is out of sight"
    await client.shot("03-by-status", "robot-picker.png")

    # Esc in the search box is still the E-STOP of every robot (and closes the list); so is Space, which types nothing.
    await page.fill(SEARCH, "robot")
    await page.press(SEARCH, "Escape")
    await client.wait("s.estop.latched.length === 20")
    assert await page.locator("#menu .picker-list").is_hidden()
    assert await page.input_value(SEARCH) == "robot"
    await page.press(SEARCH, "Space")
    assert await page.input_value(SEARCH) == "robot"
    assert await covered(page, ESTOP) == []
    assert client.errors == [], client.errors


async def test_robot73_of_a_hundred_is_found_by_search(fleet_of: StartFleet, open_client: OpenClient) -> None:
    relay = await fleet_of(100)
    client = await open_client(f"{relay.url}/?{SOFTWARE_GL}", "picker-100", 1280, 800)
    page = client.page
    await client.wait("Object.keys(s.robots).length === 100")
    await page.click(SEARCH)
    assert len(await listed(client)) == 100
    await page.keyboard.type("73")
    assert await listed(client) == ["robot73"]
    await client.shot("01-search")
    await page.keyboard.press("Enter")
    await client.wait("s.menu.selected === 'robot73'")
    assert await covered(page, ESTOP) == []
    assert client.errors == [], client.errors


async def test_twenty_robots_are_paged_in_the_vr_menu(fleet_of: StartFleet, open_client: OpenClient) -> None:
    relay = await fleet_of(20)
    client = await enter_vr(open_client, relay.url)
    # The labels as the headset shows them (its left eye's picture) are decluttered too: seen down the corridor,
    # where robots stand close together, a label another covers is a ghost, and no label drawn covers another by
    # more than COVERED_SHARE (src/label_declutter.js). Before, VR drew every label: robot13's under its neighbours'.
    await client.wait("Object.values(s.robots).filter((r) => r.visible).length === 20", 60)
    await client.frames(2)
    s = await client.state()
    rects = {name: r["labelRect"] for name, r in s["robots"].items() if not math.isnan(r["labelRect"][0])}
    drawn = {name: rect for name, rect in rects.items() if not s["robots"][name]["labelGhost"]}
    ghosts = sorted(set(rects) - set(drawn))
    assert len(rects) >= 10 and ghosts, (sorted(drawn), ghosts)
    assert all(any(overlap(rects[g], rect) > 0.3 for rect in drawn.values()) for g in ghosts), (ghosts, rects)
    covered = [(a, b) for a, b in itertools.combinations(sorted(drawn), 2) if overlap(drawn[a], drawn[b]) > 0.3]
    assert covered == [], covered
    await set_menu(client, True)

    def row(group: str) -> str:
        return f"s.menu.buttons.filter((b) => b.group === '{group}').map((b) => b.label)"

    # Six robots a page by their full names, and which they are.
    s = await client.wait("'robots:next' in s.menu.centres && s")
    labels = [b["label"] for b in s["menu"]["buttons"] if b["group"] in ("robots", "pages")]
    assert labels == ["robot1", "robot2", "robot3", "robot4", "robot5", "robot6", "‹", "robots 1-6 of 20", "›"]
    await client.shot("01-first-page")

    # › twice: robot17's page; its button selects it.
    await press_menu_button(client, "robots:next")
    await client.wait(f"{row('pages')}[1] === 'robots 7-12 of 20'")
    await press_menu_button(client, "robots:next")
    await client.wait("'robot:robot17' in s.menu.centres")
    assert await client.wait(row("robots")) == [f"robot{i}" for i in range(13, 19)]
    await press_menu_button(client, "robot:robot17")
    await client.wait("s.menu.selected === 'robot17'")
    await client.frames(2)
    await client.shot("02-robot17")
    # The panel's canvas as a headset shows it, at its own resolution (the window's screenshot is 640 pixels wide).
    png = await client.page.evaluate("""async () => {
        const { MenuPanel } = await import('/src/view/panels.js');
        const { MenuState } = await import('/src/menu_state.js');
        const menu = new MenuState();
        const robots = Array.from({ length: 20 }, (_, i) => ({ name: `robot${i + 1}`, hasCamera: false }));
        menu.setFleet(robots, true);
        menu.select('robot17');
        menu.setOpen(true);
        const panel = new MenuPanel();
        panel.update(menu, 'robots:next', 'connected');
        const png = panel.canvas.toDataURL();
        panel.dispose();
        return png;
    }""")
    save_png(png.split(",", 1)[1], "vr-robot-pages-menu.png", "vr-robot-pages.png")

    # Paged away, closed and opened again: the menu opens on robot17's page.
    await press_menu_button(client, "robots:prev")
    await client.wait(f"{row('pages')}[1] === 'robots 7-12 of 20'")
    await set_menu(client, False)
    await set_menu(client, True)
    await client.wait(f"{row('pages')}[1] === 'robots 13-18 of 20'")
    assert client.errors == [], client.errors


def overlap(a: list[float], b: list[float]) -> float:
    """How much of the smaller of two screen rectangles (x0, y0, x1, y1) the other covers."""
    w, h = min(a[2], b[2]) - max(a[0], b[0]), min(a[3], b[3]) - max(a[1], b[1])
    smaller = min((a[2] - a[0]) * (a[3] - a[1]), (b[2] - b[0]) * (b[3] - b[1]))
    return max(0.0, w) * max(0.0, h) / smaller


async def test_twenty_robots_labels_keep_their_name_and_state_legible_at_ten_metres(
    fleet_of: StartFleet, open_client: OpenClient
) -> None:
    """Every label drawn keeps each of its lines (the name, the state, a goal's progress) at least 12 px on a
    1280 x 800 page, whatever its distance: measured from the rendered label's height on the page and its layout
    (label_rule.js). Before, a label was about 2 degrees high at any distance and its state line about 4 px."""
    relay = await fleet_of(20)
    client = await open_client(f"{relay.url}/?{SOFTWARE_GL}", "labels-20", 1280, 800)
    await client.wait("Object.keys(s.robots).length === 20 && Object.values(s.robots).every((r) => r.visible)", 60)
    await client.drawn(2)
    s = await client.state()
    distances = {name: math.dist(s["eye"], r["position"]) for name, r in s["robots"].items()}
    drawn = {name: r for name, r in s["robots"].items() if r["labelOpacity"] > 0.5}
    assert len(drawn) >= 8, distances
    assert max(distances[name] for name in drawn) >= 10, distances  # some of them 10 m away or more
    small = {name: r["labelFont"] for name, r in drawn.items() if r["labelFont"] < 12}
    assert small == {}, small
    # Decluttered: of two labels that would cover each other, the nearer is drawn and the other is a ghost, so no
    # label drawn is covered by another (less than 30 % of it); a ghost is still its robot's, to be picked.
    covered = [
        (a, b)
        for a, b in itertools.combinations(sorted(drawn), 2)
        if overlap(drawn[a]["labelRect"], drawn[b]["labelRect"]) > 0.3
    ]
    assert covered == [], covered
    assert all(s["robots"][name]["labelGhost"] for name in s["robots"] if name not in drawn and distances[name] < 16)
    await client.shot("01-labels", "labels-20.png")
    assert client.errors == [], client.errors
