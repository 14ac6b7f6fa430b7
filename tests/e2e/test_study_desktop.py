"""A desktop participant does a study task in the page (issue #34): joins from the study panel, reads the
instruction, presses Start, sends robot1 into the task's region with the goal tool, then answers the raw NASA-TLX
(sliders) and the SUS (radio buttons) with the mouse; `xr-relay study export` then holds the rows the page gave."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from tests.conftest import RunningRelay
from tests.helpers.browser import SOFTWARE_GL, Client, OpenClient, fixture, wait_until
from tests.helpers.study import exported
from tests.helpers.study import study_relay as running_study
from tests.helpers.study_files import DRIVE_STUDY, GOAL_AT

#: The SUS answers clicked, item by item, and their score: (3+3+4+4+3+3+4+4+3+3) * 2.5.
SUS = [4, 2, 5, 1, 4, 2, 5, 1, 4, 2]
SUS_SCORE = 85.0
#: Where each TLX slider is clicked, as a share of its width.
TLX_AT = [0.2, 0.1, 0.5, 0.3, 0.7, 0.05]


@fixture
async def study_relay(tmp_path: Path) -> AsyncIterator[tuple[RunningRelay, Path]]:
    async with running_study(tmp_path, DRIVE_STUDY) as running:
        yield running, tmp_path


async def page_point(client: Client, x: float, y: float) -> tuple[float, float]:
    px, py = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0)", [x, y])
    return px, py


async def test_a_desktop_participant_does_a_task_and_answers_tlx_and_sus_in_the_page(
    study_relay: tuple[RunningRelay, Path], open_client: OpenClient
) -> None:
    running, folder = study_relay
    client = await open_client(f"{running.url}/?{SOFTWARE_GL}", "study-desktop", 1280, 760)
    page = client.page
    await client.wait("s.study && s.study.phase === 'waiting'")
    await page.select_option("#study select[name=participant]", "P01")
    await page.click('#study button[data-study="join"]')
    await client.wait("s.study.phase === 'ready' && s.study.participant === 'P01'")
    assert "Send robot1 into chemical storage." in await page.inner_text("#study")
    await client.shot("01-instruction", "study-instruction.png")

    await page.click('#study button[data-study="start"]')
    await client.wait("s.study.phase === 'task'")
    relay = running.relay
    await wait_until(lambda: _near(relay, "robot1", (3.0, 1.0)), 20, "robot1 placed where the task starts")
    # Select robot1 in the menu, then click on the floor of chemical storage with the goal tool: a goal.
    await page.click('#menu button[data-button="robot:robot1"]')
    await client.wait("s.menu.selected === 'robot1'")
    await page.click('#menu button[data-button="tool:goal"]')
    await client.wait("s.menu.tool === 'goal'")
    gx, gy = await page_point(client, *GOAL_AT)
    for _ in range(3):  # a goal the relay dropped as stale (a stall of the shared loop) is sent again
        await page.mouse.click(gx, gy)
        try:
            await wait_until(lambda: relay.fleet.status("robot1", relay.clock())["mode"] == "navigating", 10, "goal")
            break
        except AssertionError:
            continue
    await client.shot("02-task")

    # The relay sees robot1 in the region: the task ends, and the page asks the TLX.
    await client.wait("s.study.phase === 'questions' && s.study.questionnaire === 'tlx'", 90)
    sliders = page.locator("#study input[type=range]")
    assert await sliders.count() == 6
    for i, share in enumerate(TLX_AT):
        box = await sliders.nth(i).bounding_box()
        assert box is not None
        await page.mouse.click(box["x"] + share * box["width"], box["y"] + box["height"] / 2)
    tlx = await client.wait("s.study.tlx[5] !== 50 && s.study.tlx")
    assert len(tlx) == 6 and tlx[0] < tlx[2] < tlx[4], tlx
    await client.shot("03-tlx", "study-tlx.png")
    await page.click('#study button[data-study="answer"]')

    await client.wait("s.study.questionnaire === 'sus'")
    await page.click('#study button[data-study="answer"]')  # nothing answered: the page says what is missing
    assert "please answer items 1, 2, 3" in await page.inner_text("#study .missing")
    for item, answer in enumerate(SUS):
        await page.click(f'#study .scale[data-item="{item + 1}"] input[value="{answer}"]')
    await client.wait("s.study.sus.every((a) => a !== null)")
    await client.shot("04-sus", "study-sus.png")
    await page.click('#study button[data-study="answer"]')
    await client.wait("s.study.phase === 'ready' && s.study.done === 1")  # the next condition's instruction
    await client.shot("05-next-condition")
    assert client.errors == []

    await running.runner.cleanup()  # the run's last state written as the relay stops
    values = await exported(folder)
    assert values[("desktop", "reach-storage", "success")] == 1.0
    assert 0 < values[("desktop", "reach-storage", "time_s")] < 120
    assert values[("desktop", "reach-storage", "commands")] >= 1
    assert values[("desktop", "reach-storage", "tlx")] == pytest.approx(sum(tlx) / 6)
    assert values[("desktop", "", "sus")] == SUS_SCORE


def _near(relay: object, robot: str, where: tuple[float, float]) -> bool:
    from relay.station.core import Relay

    assert isinstance(relay, Relay)
    pose = relay.fleet.snapshot(relay.clock())[robot]["pose"]
    return pose is not None and abs(pose["x"] - where[0]) < 0.05 and abs(pose["y"] - where[1]) < 0.05
