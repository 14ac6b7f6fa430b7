"""Issue #30, item 1: schedules are made and changed from the desktop page. The form under the schedule list makes one
(the demo's targets on robot1, its first run seconds away, every minute), the list shows it when the relay says so, its
round runs (the schedule's mission reaches the page and the list's last run says started); Edit changes its repeat
(only that is sent); bad input gets the relay's error, naming the field, beside the form, and nothing is added; and
Remove, confirmed in the page (never window.confirm), takes it away."""

from __future__ import annotations

import asyncio
import time

from playwright.async_api import Browser

from relay.cli.options import Options
from relay.config import load_config
from relay.inspection.wire import ScheduleChange
from relay.session.clients import Client
from tests.conftest import ROOT, start_relay
from tests.helpers import browser as pages
from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station, native_dialogs, wait_until
from tests.helpers.inspection import TOKEN, operator
from tests.helpers.schedule_form import FORM, fill_schedule

ROW = "#findings li[data-schedule='rounds']"
DEMO_TARGETS = ("spill", "panels", "leak")
CHANGEABLE = ("mission", "start", "repeat", "windows", "blackouts", "priority", "on_busy")


async def test_a_schedule_is_made_runs_is_changed_and_removed_from_the_desktop(
    station: Station, open_client: OpenClient
) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "schedule-form", 1280, 900)
    page = client.page
    native = native_dialogs(page)
    scheduler = station.running.relay.inspection.scheduler
    schedules = station.running.relay.inspection.schedules
    commands: list[ScheduleChange] = []  # as the relay parsed them
    change = schedules.change

    async def spy(client_: Client, command: ScheduleChange) -> None:
        commands.append(command)
        await change(client_, command)

    schedules.change = spy  # type: ignore[method-assign,assignment]
    await client.wait("s.inspection.targets >= 3 && s.inspection.scheduleForm.visible")

    # The demo's targets, in order, on robot1, every minute from 3 s from now: listed once the relay says so, and the
    # form is cleared and closed.
    await fill_schedule(page, "rounds", DEMO_TARGETS, "robot1", "1", 3)
    await page.click(f"{FORM} button[data-act='save']")
    await page.wait_for_selector(ROW)
    await client.wait("!s.inspection.scheduleForm.pending && !s.inspection.scheduleForm.open")
    assert not await page.locator(f"{FORM} input").count(), "closed"
    record = scheduler.get("rounds")
    assert record is not None and record.repeat == 60.0 and record.on_busy == "wait"
    assert record.mission == {"robot": "robot1", "steps": [{"inspect": t} for t in DEMO_TARGETS]}
    assert abs(record.start - (time.time() + 3)) < 10, record.start

    # Its round runs: the schedule's mission reaches the page, and the list says its last run started.
    ran = await client.wait(
        "s.inspection.schedules.find((x) => x.schedule === 'rounds' && x.last === 'started' "
        "&& s.inspection.owners[x.mission] === 'schedule rounds')",
        30,
    )
    assert ran["mission"].endswith(".robot1"), ran
    assert "last started" in await page.inner_text(ROW)

    # Edit: the form filled from the list; the repeat changed to 2 minutes is all that is sent.
    await page.click(f"{ROW} button[data-schedule-edit='rounds']")
    assert await page.input_value(f"{FORM} input[name='repeat']") == "1"
    assert await page.get_attribute(f"{FORM} input[name='schedule']", "readonly") is not None
    await page.fill(f"{FORM} input[name='repeat']", "2")
    await client.shot("01-edit", "schedule-form.png")
    await page.click(f"{FORM} button[data-act='save']")
    await client.wait("s.inspection.schedules.some((x) => x.schedule === 'rounds' && x.repeat === 120)")
    await client.wait("s.inspection.scheduleForm.editing === null && !s.inspection.scheduleForm.open")
    changed = scheduler.get("rounds")
    assert changed is not None and changed.repeat == 120.0
    assert (changed.mission, changed.start, changed.windows) == (record.mission, record.start, record.windows)
    update = commands[-1]
    assert (update.action, update.repeat) == ("update", 120.0), update
    assert [f for f in CHANGEABLE if getattr(update, f) is not None] == ["repeat"], update

    # Bad input: a new schedule every half minute, then with a window of no day. Each gets the relay's error beside
    # the form, its field marked, and nothing is added.
    await page.click("#findings button[data-schedule-new]")
    await page.fill(f"{FORM} input[name='schedule']", "quick")
    await page.check(f"{FORM} input[name='target'][value='spill']")
    await page.fill(f"{FORM} input[name='repeat']", "0.5")
    await page.click(f"{FORM} button[data-act='save']")
    error = page.locator(f"{FORM} .error")
    await error.wait_for(state="visible")
    assert "schedule/add: repeat must be at least 60 s" in await error.inner_text()
    assert await page.locator(f"{FORM} [data-field='repeat'].invalid").count() == 1
    await page.fill(f"{FORM} input[name='repeat']", "1")
    for day in ("mon", "tue", "wed", "thu", "fri", "sat", "sun"):
        await page.uncheck(f"{FORM} input[name='days-0'][value='{day}']")
    await page.click(f"{FORM} button[data-act='save']")
    await client.wait("s.inspection.scheduleForm.field === 'windows'")
    assert "field 'windows'" in await error.inner_text() and "windows[0].days" in await error.inner_text()
    assert await page.locator(f"{FORM} [data-field='windows'].invalid").count() == 1
    assert scheduler.names() == ["rounds"], "nothing added"
    assert await page.locator("#findings li[data-schedule]").count() == 1
    await page.click(f"{FORM} button[data-act='cancel']")

    # Remove, confirmed in the page's own dialog (never window.confirm): the row leaves the list.
    await page.click(f"{ROW} button[data-schedule-remove='rounds']")
    await page.wait_for_selector("#confirm-dialog[open]")
    assert "rounds" in await page.inner_text("#confirm-dialog p")
    await page.click("#confirm-dialog button[value='yes']")
    await page.wait_for_selector(ROW, state="detached")
    await wait_until(lambda: scheduler.get("rounds") is None, 10, "removed at the relay")
    assert native == [], native
    assert client.errors == [], client.errors


async def test_a_viewer_sees_the_schedules_and_no_form(browser: Browser) -> None:
    """A viewer's schedule commands are ``forbidden``: its page lists the schedules, with no form and no buttons."""
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(token=TOKEN, allow_viewers=True))
    ana = await operator(running)
    try:
        added = await ana.request(
            {
                "identifier": "schedule/add", "schedule": "nightly", "mission": {"targets": list(DEMO_TARGETS)},
                "start": time.time() + 3600, "repeat": 3600, "windows": [{"days": ["mon", "fri"], "hours": [8, 17]}],
            },
            30,
        )  # fmt: skip
        assert added["identifier"] == "ack", added
        page = await browser.new_page(viewport={"width": 1280, "height": 760})
        viewer = pages.Client(page, "schedule-viewer")
        await page.goto(f"{running.url}/?{SOFTWARE_GL}&name=Vic")  # no token: a viewer
        await viewer.wait("s.connected && s.inspection.schedules.length === 1 && s.inspection.scheduleForm")
        row = page.locator("#findings li[data-schedule='nightly']")
        await row.wait_for()
        assert "spill, panels, leak (the fleet)" in await row.inner_text()
        assert (await viewer.state())["inspection"]["scheduleForm"]["visible"] is False
        assert await page.locator("#findings .schedule-form").count() == 0, "no form"
        assert (
            await page.locator("#findings button[data-schedule-edit], #findings button[data-schedule-remove]").count()
            == 0
        )
        assert viewer.errors == [], viewer.errors
        await page.close()
    finally:
        await ana.close()
        await running.runner.cleanup()
