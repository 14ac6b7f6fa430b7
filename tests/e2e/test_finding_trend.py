"""A reading's trend on the desktop finding card (issue 30, items 3 and 4): three rounds of the simulator's gas, a
minute apart as its spill grows, make a ``changed`` finding through the relay's own store and rule; its card draws
the three readings as a sparkline with the threshold dashed and labelled with its unit."""

from __future__ import annotations

import time
from typing import Any

from relay.config import load_config
from relay.inspection.records import CaptureRecord, FindingRecord
from relay.sim.world import SimWorld
from tests.conftest import ROOT
from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station

#: 2.5 m south of the spill's gas source: under its limit at first, and rising toward it as the spill grows.
PLACE = (1.8, 5.7)


async def _trend_finding(station: Station) -> FindingRecord:
    """Three captures of the spill with the simulator's readings at ``PLACE`` (its world stepped a minute between
    them, by hand), stored by the relay; the third's trend finding made by the relay's rule and announced."""
    captures: Any = station.running.relay.inspection.captures
    world = SimWorld(load_config(ROOT / "robots.yaml"), lambda *args: None)
    sensors = {s.name: s for s in station.running.relay.config.robots[0].sensors}
    now = time.time() - 180
    stored = None
    for n in range(3):
        fields = world.fields_now()
        readings = {name: fields[spec.hazard].mean(*PLACE) for name, spec in sensors.items()}
        record = CaptureRecord(f"c-trend-{n}", "robot1", now + 60 * n, *PLACE, 1.57, readings, f"m-trend-{n}.robot1",
                               "spill")  # fmt: skip
        stored = await captures._store(lambda s, r=record: s.add_capture(r, None))
        for _ in range(60):
            world.step(1.0)
    assert stored is not None
    trends = await captures._changes.trends(stored, sensors)
    [finding] = captures._changes.toward_limits(stored, trends, (1.8, 8.2))
    await captures._announce(await captures._store(lambda s: s.add_finding(finding)), stored)
    return finding


async def test_a_trend_finding_card_draws_the_rounds_and_the_limit(station: Station, open_client: OpenClient) -> None:
    finding = await _trend_finding(station)
    assert finding.trend is not None and finding.note.startswith("trending toward its limit: gas ")
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "finding-trend", 1280, 760)
    page = client.page
    await page.click(f"#findings li[data-finding='{finding.id}']", timeout=30_000)
    await page.wait_for_selector("#findings figure.trend svg")
    svg = page.locator("#findings figure.trend svg")
    assert await svg.locator("circle").count() == 3
    assert await svg.locator("line.limit").count() == 1
    assert await svg.locator("text").text_content() == "400 ppm"
    dash = await svg.locator("line.limit").evaluate("(l) => getComputedStyle(l).strokeDasharray")
    assert dash not in ("", "none"), dash
    # The points rise toward the dashed line: SVG y grows downwards, the threshold is above every reading.
    ys = [float(await c.get_attribute("cy") or "nan") for c in await svg.locator("circle").all()]
    limit = float(await svg.locator("line.limit").get_attribute("y1") or "nan")
    assert ys[0] > ys[1] > ys[2] > limit, (ys, limit)
    caption = await page.inner_text("#findings figure.trend figcaption")
    assert caption == "gas (ppm) over the last 3 rounds, its limit dashed", caption
    await svg.scroll_into_view_if_needed()
    await client.shot("01-trend")
    assert not client.errors, client.errors
