"""A participant answers the study's questionnaires in the headset (issue #34), on IWER's emulated Quest 3: P02, whose
first condition is the headset, joins and starts in the page, enters VR, and when the task's time is up the menu
opens on the raw NASA-TLX and then the SUS, an item at a time; each answer is a press of the controller's ray on the
menu, and `xr-relay study export` then holds what was pressed."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from tests.conftest import RunningRelay
from tests.helpers.browser import HEADSET, SOFTWARE_GL, VR_VIEW, OpenClient, fixture
from tests.helpers.study import exported
from tests.helpers.study import study_relay as running_study
from tests.helpers.study_files import DRIVE_STUDY
from tests.helpers.xr import present, press_menu_button

#: The SUS answers pressed, item by item, and their score: (4+3+3+4+2+3+4+4+3+3) * 2.5.
SUS = [5, 2, 4, 1, 3, 2, 5, 1, 4, 2]
SUS_SCORE = 82.5
#: The task ends by its time (the headset's participant drives nothing here): a short one.
TIME_LIMIT_S = 3


@fixture
async def study_relay(tmp_path: Path) -> AsyncIterator[tuple[RunningRelay, Path]]:
    async with running_study(
        tmp_path, DRIVE_STUDY.replace("time_limit: 120", f"time_limit: {TIME_LIMIT_S}")
    ) as running:
        yield running, tmp_path


async def test_the_tlx_and_the_sus_are_answered_in_the_headset_by_pointing(
    study_relay: tuple[RunningRelay, Path], open_client: OpenClient
) -> None:
    running, folder = study_relay
    client = await open_client(f"{running.url}/?{HEADSET}&{SOFTWARE_GL}", "study-vr", *VR_VIEW)
    page = client.page
    # The participant joins and starts at the page, then puts the headset on: its window a desktop's meanwhile (in
    # the small window of a VR test the study panel's Start lay outside it).
    await page.set_viewport_size({"width": 1280, "height": 760})
    await client.wait("s.study && s.study.phase === 'waiting'")
    await page.select_option("#study select[name=participant]", "P02")
    await page.click('#study button[data-study="join"]')
    await client.wait("s.study.phase === 'ready' && s.study.condition === 'headset'")
    await page.click('#study button[data-study="start"]')
    width, height = VR_VIEW
    await page.set_viewport_size({"width": width, "height": height})
    await present(client)

    # The time is up: the menu opens on the TLX's first scale, its answers a ray's reach.
    await client.wait("s.study.questionnaire === 'tlx' && s.menu.open && 'study:tlx:75' in s.menu.centres", 60)
    await press_menu_button(client, "study:tlx:75")
    await client.wait("s.study.tlx[0] === 75")
    await press_menu_button(client, "study:send")  # the other scales as they start, in the middle

    await client.wait("s.study.questionnaire === 'sus' && 'study:sus:1' in s.menu.centres", 30)
    await client.shot("01-sus-in-the-headset", "vr-study-sus.png")
    for item, answer in enumerate(SUS):
        await press_menu_button(client, f"study:sus:{answer}")
        await client.wait(f"s.study.sus[{item}] === {answer}", 20)
    await press_menu_button(client, "study:send")
    await client.wait("s.study.phase === 'ready' && s.study.done === 1", 30)  # on to the next condition
    assert client.errors == [], client.errors

    await running.runner.cleanup()  # the run's last state written as the relay stops
    values = await exported(folder)
    assert values[("headset", "reach-storage", "tlx")] == pytest.approx((75 + 5 * 50) / 6)
    assert values[("headset", "", "sus")] == SUS_SCORE
