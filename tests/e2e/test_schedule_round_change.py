"""Issue #30 from the desktop, end to end on the simulator: last round's capture of the spill is in the database (a
mission run before the page opened); the lead makes a schedule in the page; its round drives robot1 to the spill,
whose simulated chemical has spread since (robots.yaml's ``sim.spill_growth``, quickened here so that seconds
apart are enough); the relay's comparison makes a ``changed`` finding; the lead opens it from the list and wipes the
slider between the round before and this one, the change's outline over the new image."""

from __future__ import annotations

import asyncio
import dataclasses
import io
from pathlib import Path

import pytest
from PIL import Image, ImageChops
from playwright.async_api import Browser

from relay.config import SpillGrowth, load_config
from relay.sim.camera import embree_available
from tests.conftest import LOAD_SLACK, ROOT
from tests.helpers.browser import SOFTWARE_GL, Client, open_wipe, wiped
from tests.helpers.inspection import TOKEN, operator, relay_with_database
from tests.helpers.schedule_form import FORM, fill_schedule

#: Robots.yaml's spill spreads 10 % of its size a minute, which a round a minute later sees as a score of 0.037
#: (threshold 0.02). At 90 % a minute the scheduled round, at least 10 s after the last one (its first run is 10 s
#: after the form is saved), sees it grown by 15 % or more; it stops growing only after two minutes and more.
FAST_SPREAD = SpillGrowth(rate=0.9, limit=3.0)


async def test_a_schedule_made_in_the_page_runs_a_round_that_finds_the_spill_grown_and_the_card_wipes(
    browser: Browser, tmp_path: Path
) -> None:
    if not embree_available():
        pytest.skip("the simulated camera's renders need Embree (embreex, installed by make setup)")
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    config = dataclasses.replace(config, sim=dataclasses.replace(config.sim, spill_growth=FAST_SPREAD))
    running = await relay_with_database(config, tmp_path)
    lead = await operator(running)
    page = await browser.new_page(viewport={"width": 1280, "height": 900})
    try:
        # Last round: the spill inspected once, before anyone made a schedule.
        reply = await lead.request(
            {"identifier": "mission/start", "robot": "robot1", "steps": [{"inspect": "spill"}]}, timeout=30
        )
        assert reply["identifier"] == "ack", reply
        first = await lead.wait_for(
            lambda m: m["identifier"] == "finding" and m["target"] == "spill" and m["source"] == "rule", 90 + LOAD_SLACK
        )
        await page.goto(f"{running.url}/?{SOFTWARE_GL}&name=Lea#token={TOKEN}")
        client = Client(page, "schedule-round-change")
        await client.wait("s.connected && s.inspection.targets >= 3 && s.inspection.scheduleForm.visible", 30)
        await client.wait("s.inspection.findings.some((f) => f.id === arg)", 30, first["id"])

        # The schedule, made in the page: the spill on robot1 every minute, its first run in 3 s.
        await fill_schedule(page, "spill-watch", ["spill"], "robot1", "1", 3)
        await page.click(f"{FORM} button[data-act='save']")
        await page.wait_for_selector("#findings li[data-schedule='spill-watch']")
        # Its round runs and finds the spill grown: a changed finding, with the change outlined, in the list.
        changed = await client.wait(
            "s.inspection.findings.find((f) => f.target === 'spill' && f.status === 'changed' && f.region)",
            90 + LOAD_SLACK,
        )
        schedules = (await client.state())["inspection"]["schedules"]
        ran = next(s for s in schedules if s["schedule"] == "spill-watch")
        assert ran["last"] in ("started", "done") and ran["mission"], ran
        made = next(m for _, m in lead.messages if m["identifier"] == "finding" and m["id"] == changed["id"])
        assert made["baseline"] == first["capture"] and made["mission"] == ran["mission"], made

        # Opened from the list: before (last round's) and after (this one's) in one box, the outline over the after.
        await page.click(f"#findings li[data-finding='{changed['id']}']")
        await open_wipe(client)
        shots = {p: Image.open(io.BytesIO(await wiped(client, p))).convert("RGB") for p in (10, 90)}
        assert ImageChops.difference(shots[10], shots[90]).getbbox() is not None, "the slider shows the other round"
        await wiped(client, 50)
        await client.shot("01-scheduled-round-changed", "schedule-round-change.png")
        assert client.errors == [], client.errors
    finally:
        await page.close()
        await lead.close()
        await running.runner.cleanup()
