"""A change finding's desktop card (issue 30, item 4): the before image (the baseline capture's) and the after image
stacked in one box, a slider under them wiping between the two, the change's outline over the after image."""

from __future__ import annotations

import asyncio
import io
import time
from typing import Any

import pytest
from PIL import Image, ImageChops

from relay.inspection.change import SCORE_THRESHOLD
from relay.inspection.records import CaptureRecord, FindingRecord
from relay.sim.camera import embree_available
from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station
from tests.helpers.inspection import SIZE, SPILL_VIEW, spill_rounds


async def _changed_finding(station: Station) -> FindingRecord:
    """Two captures of the spill, grown between them, and the ``changed`` finding comparing them, made and announced
    through the relay's own capture path (what a mission's second round does)."""
    if not embree_available():
        pytest.skip("the simulated camera's renders need Embree (embreex, installed by make setup)")
    captures: Any = station.running.relay.inspection.captures
    first, later, score, outline = await asyncio.to_thread(spill_rounds)
    assert score > SCORE_THRESHOLD and outline is not None, score
    now = time.time()
    stored = []
    for index, jpeg in enumerate((first, later)):
        record = CaptureRecord(f"c-wipe-{index}", "robot1", now - 60 + 60 * index, *SPILL_VIEW, {}, None, "spill",
                               None, SIZE, SIZE)  # fmt: skip
        stored.append(await captures._store(lambda s, r=record, j=jpeg: s.add_capture(r, j)))
    before, after = stored
    first_finding = FindingRecord("f-wipe-0", before.id, "robot1", 1.8, 8.2, "ok", "within thresholds", "rule",
                                  before.t, before.t, None, "spill")  # fmt: skip
    changed = FindingRecord("f-wipe-1", after.id, "robot1", 1.8, 8.2, "changed", "changed since the last round",
                            "rule", after.t, after.t, None, "spill", outline, round(score, 4), before.id)  # fmt: skip
    for finding, capture in ((first_finding, before), (changed, after)):
        await captures._announce(await captures._store(lambda s, f=finding: s.add_finding(f)), capture)
    return changed


def _crop(png: bytes) -> Image.Image:
    return Image.open(io.BytesIO(png)).convert("RGB")


async def test_a_change_finding_wipes_between_before_and_after(station: Station, open_client: OpenClient) -> None:
    changed = await _changed_finding(station)
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "before-after", 1280, 760)
    page = client.page
    await page.click(f"#findings li[data-finding='{changed.id}']", timeout=30_000)
    await page.wait_for_selector("#findings .wipe img.before")
    loaded = "() => [...document.querySelectorAll('#findings .wipe img')].every((i) => i.naturalWidth > 0)"
    await page.wait_for_function(loaded, timeout=30_000)
    assert await page.locator("#findings .wipe img").count() == 2
    await page.wait_for_selector("#findings .wipe .after polygon")
    labels = await page.inner_text("#findings .wipe-labels")
    assert "before (" in labels and "after (" in labels, labels
    box = page.locator("#findings .capture.wipe")
    slider = page.locator("#findings input[data-wipe]")
    shots = {}
    for position in (10, 90):
        await slider.fill(str(position))
        await client.wait(f"s.inspection.card.wipe === {position}")
        await page.wait_for_timeout(100)  # the clip painted
        shots[position] = _crop(await box.screenshot())
    assert ImageChops.difference(shots[10], shots[90]).getbbox() is not None
    # The outline is the after image's: a click on what the slider shows of it still marks a region there.
    await slider.fill("10")  # after, right of the divide: nine tenths of it
    after = page.locator("#findings .wipe .after img")
    area = await after.bounding_box()
    assert area is not None
    await page.mouse.click(area["x"] + area["width"] * 0.3, area["y"] + area["height"] * 0.6)
    await client.wait("s.inspection.review.pending || s.inspection.review.proposal", 30)
    await slider.fill("50")  # half of each for the picture
    await client.wait("s.inspection.card.wipe === 50")
    await client.shot("01-before-after", "finding-before-after.png")
    assert not client.errors, client.errors
