"""A change finding's desktop card (issue 30, item 4): the before image (the baseline capture's) and the after image
stacked in one box, a slider under them wiping between the two, the change's outline over the after image."""

from __future__ import annotations

import io

from PIL import Image, ImageChops

from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station, open_wipe, wiped
from tests.helpers.inspection import two_rounds


def _crop(png: bytes) -> Image.Image:
    return Image.open(io.BytesIO(png)).convert("RGB")


async def test_a_change_finding_wipes_between_before_and_after(station: Station, open_client: OpenClient) -> None:
    _, changed, _ = await two_rounds(station.running)  # the spill grown between two rounds: changed
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "before-after", 1280, 760)
    page = client.page
    await page.click(f"#findings li[data-finding='{changed.id}']", timeout=30_000)
    await open_wipe(client)
    assert await page.locator("#findings .wipe img").count() == 2
    labels = await page.inner_text("#findings .wipe-labels")
    assert "before (" in labels and "after (" in labels, labels
    slider = page.locator("#findings input[data-wipe]")
    shots = {position: _crop(await wiped(client, position)) for position in (10, 90)}
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
