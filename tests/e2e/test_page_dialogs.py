"""Issue #31, finding 3: no native dialog anywhere, and E-STOP's keys reach it whatever is open. A shift-click named
its target in `window.prompt`, which held the whole page (no frame, no key) until answered; the page's own dialog
keeps the page drawing, Enter names the target, Esc cancels, and Space and Esc stop the fleet while it is open. The
"no immersive VR device" notice can be closed, and stays closed for the tab."""

from __future__ import annotations

from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station, confirm_reset, native_dialogs, wait_until

ROBOTS = ("robot1", "robot2", "robot3")


def latched(station: Station) -> list[str]:
    return [r for r in ROBOTS if station.status(r)["estopped"]]


async def test_the_target_dialog_is_in_the_page_and_estop_keys_work_while_it_is_open(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "dialogs", 1280, 760)
    page = client.page
    native = native_dialogs(page)
    targets = len(station.running.relay.inspection.targets)
    await client.drawn(2)  # framed: the first frames place the view
    px, py = await page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [10.5, 2.0])
    await client.shot("00-before-shift-click")
    await page.keyboard.down("Shift")
    await page.mouse.click(px, py)
    await page.keyboard.up("Shift")
    await page.wait_for_selector("#target-dialog[open]")
    prompt = await page.inner_text("#target-dialog .prompt")
    assert prompt == "Name of the new target at (10.5, 2.0)", prompt
    suggestion = await page.input_value("#target-dialog input")
    assert suggestion.startswith("target-"), suggestion
    # The page goes on while the operator thinks: frames are drawn (a native prompt stopped them all).
    await client.drawn(3, 20)
    await client.shot("01-target-dialog")

    # Space, the cursor in the name: every robot stops and latches; nothing is typed, the dialog waits.
    await page.keyboard.press("Space")
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "Space latched the fleet with the dialog open")
    assert await page.input_value("#target-dialog input") == suggestion
    assert await page.is_visible("#target-dialog")
    # The banner's Reset is clickable with the dialog open (no modal backdrop takes the clicks).
    await confirm_reset(page)
    await wait_until(lambda: latched(station) == [], 5, "released")

    # Enter names it.
    await page.fill("#target-dialog input", "valve-7")
    await page.press("#target-dialog input", "Enter")
    await page.wait_for_selector("#target-dialog", state="hidden")
    await wait_until(lambda: "valve-7" in station.running.relay.inspection.targets, 10, "valve-7 added")
    valve = station.running.relay.inspection.targets["valve-7"]
    assert abs(valve.x - 10.5) < 0.3 and abs(valve.y - 2.0) < 0.3, valve

    # Esc cancels the next one, and is E-STOP as everywhere on the page.
    await page.keyboard.down("Shift")
    await page.mouse.click(px, py)
    await page.keyboard.up("Shift")
    await page.wait_for_selector("#target-dialog[open]")
    await page.keyboard.press("Escape")
    await page.wait_for_selector("#target-dialog", state="hidden")
    await wait_until(lambda: latched(station) == list(ROBOTS), 5, "Esc latched the fleet")
    await client.wait("s.inspection.targets === arg", 5, targets + 1)
    assert len(station.running.relay.inspection.targets) == targets + 1, "the cancelled target was not added"
    assert native == [], native
    assert client.errors == [], client.errors


async def test_the_no_vr_device_notice_can_be_closed_and_stays_closed(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "vr-notice", 1280, 760)
    page = client.page
    notice = page.locator("#vr-notice")
    await notice.wait_for(state="visible", timeout=10_000)
    assert "no immersive VR device" in await notice.inner_text()
    await notice.locator("button.close").click()
    await notice.wait_for(state="hidden")
    # Reloaded in the same tab: not shown again for the same reason.
    await page.reload()
    await client.wait("s.connected && Object.keys(s.robots).length > 0", 30)
    await client.wait("document.querySelector('#vr-notice strong') !== null", 10)  # the page asked again
    assert not await notice.is_visible()
    assert client.errors == [], client.errors


CUT_LABELS = """() => [...document.querySelectorAll('#menu button')]
  .filter((b) => b.offsetParent !== null && b.scrollWidth > b.clientWidth + 1)
  .map((b) => `${b.textContent} (${b.scrollWidth} px in ${b.clientWidth})`)"""


async def test_no_menu_label_is_cut(station: Station, open_client: OpenClient) -> None:
    """The Options row read "Overvie": a label wider than its button was clipped. Rows wrap now."""
    for width, height in ((1280, 800), (1024, 640)):
        client = await open_client(f"{station.url}/?{SOFTWARE_GL}", f"labels-{width}", width, height)
        if width < 1100:  # compact: the menu starts collapsed to its E-STOP
            await client.page.click('#panel-toggles button[data-panel="menu"]')
        await client.page.click('#menu button[data-button="robot:robot1"]')  # its Stop button joins the menu
        await client.wait("s.menu.selected === 'robot1'")
        await client.drawn(1, 20)
        cut = await client.page.evaluate(CUT_LABELS)
        await client.shot(f"menu-{width}x{height}")
        assert cut == [], cut
        assert client.errors == [], client.errors
