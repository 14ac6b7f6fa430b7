"""Groups of robots on the desktop (issue #31): robots.yaml puts robot1 and robot2 in the North crew; the menu's group
row lists the team and the room they all stand in (the corridor). Stop on the team latches an E-STOP on its two
robots and not on robot3, and so does saying "stop north crew"; the picked targets, with the team chosen, go to the
team's robots alone (robot1 and robot2), and robot3 stays idle."""

from __future__ import annotations

import asyncio
import dataclasses
from pathlib import Path

from playwright.async_api import Browser

from relay.config import load_config
from tests.conftest import ROOT
from tests.helpers.browser import SOFTWARE_GL, Client, confirm_reset, native_dialogs, wait_until
from tests.helpers.inspection import TOKEN, relay_with_database
from tests.helpers.speech import FAKE_SPEECH, say

TEAM = "North crew"


async def test_a_team_is_stopped_together_and_its_robots_alone_get_the_picked_targets(
    browser: Browser, tmp_path: Path
) -> None:
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    teams = {"robot1": TEAM, "robot2": TEAM}
    robots = tuple(dataclasses.replace(r, team=teams.get(r.name)) for r in config.robots)
    running = await relay_with_database(dataclasses.replace(config, robots=robots), tmp_path)
    page = await browser.new_page(viewport={"width": 1280, "height": 900})
    native = native_dialogs(page)
    fleet = running.relay.fleet

    def latched() -> list[str]:
        return sorted(r for r in ("robot1", "robot2", "robot3") if fleet.status(r, 0.0)["estopped"])

    try:
        await page.add_init_script(FAKE_SPEECH)
        await page.goto(f"{running.url}/?{SOFTWARE_GL}&name=Lea#token={TOKEN}")
        client = Client(page, "robot-groups")
        state = await client.wait("s.connected && s.groups.list.length >= 2 && s", 30)
        assert state["groups"]["list"] == [
            {"id": f"team:{TEAM}", "robots": ["robot1", "robot2"]},
            {"id": "room:corridor", "robots": ["robot1", "robot2", "robot3"]},
        ], state["groups"]
        select = page.locator("#menu .row.group select")
        stop = page.locator("#menu .row.group button[data-group-act='stop']")
        assert await stop.is_disabled(), "no group chosen: nothing to stop"
        await select.select_option(f"team:{TEAM}")
        await client.wait("s.groups.chosen === arg", 10, f"team:{TEAM}")
        assert await stop.inner_text() == f"Stop {TEAM} (2)"

        # Stop the team: its two robots latch, robot3 goes on.
        await stop.click()
        await wait_until(lambda: latched() == ["robot1", "robot2"], 10, "the team's robots latched")
        await client.shot("01-team-stopped")
        assert latched() == ["robot1", "robot2"], "robot3, outside the team, is not stopped"
        question = await confirm_reset(page)
        assert "robot1" in question and "robot2" in question and "robot3" not in question, question
        await wait_until(lambda: latched() == [], 10, "the reset")
        # By voice (the headset's way too): "stop north crew" stops the team at once, no confirmation asked.
        heard = await say(client, "stop north crew")
        assert heard["result"] == "emergency stop of North crew: robot1, robot2", heard
        await wait_until(lambda: latched() == ["robot1", "robot2"], 10, "the team's robots latched by voice")
        await confirm_reset(page)
        await wait_until(lambda: latched() == [], 10, "the reset")

        # The picked targets, with the team chosen: to its robots alone.
        await client.wait("s.inspection.targets >= 3")
        for target in ("spill", "leak"):
            await page.click(f"#findings li[data-target='{target}']")
        start = page.locator("#findings button[data-mission='start']")
        assert await start.inner_text() == f"Inspect 2 with {TEAM} (2)"
        await start.click()
        missions = await client.wait("Object.keys(s.inspection.missions).length === 2 && s.inspection.missions", 30)
        assert sorted(missions) == ["robot1", "robot2"], missions
        await client.shot("02-team-inspects", "robot-groups.png")
        assert native == [] and client.errors == [], (native, client.errors)
    finally:
        await page.close()
        await running.runner.cleanup()
