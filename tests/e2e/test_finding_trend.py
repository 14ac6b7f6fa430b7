"""A reading's trend on the desktop finding card (issue 30, items 3 and 4): three rounds of the simulator's gas, a
minute apart as its spill grows, make a ``changed`` finding through the relay's own store and rule; its card draws
the three readings as a sparkline with the threshold dashed and labelled with its unit."""

from __future__ import annotations

import base64
import time
from typing import Any

from relay.config import load_config
from relay.inspection.records import CaptureRecord, FindingRecord
from relay.sim.world import SimWorld
from tests.conftest import ROOT
from tests.helpers.browser import ARTIFACTS, SOFTWARE_GL, OpenClient, Station

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
    found: list[FindingRecord] = captures._changes.toward_limits(stored, trends, (1.8, 8.2))
    [finding] = found
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


async def test_the_vr_card_draws_the_trend_between_its_buttons(station: Station, open_client: OpenClient) -> None:
    """The VR card's canvas (drawn as in a headset, without entering one) for the finding message the relay sent: the
    trend's box holds the dashed threshold and the line through the rounds, in their colours, and nothing is drawn
    there for a finding without a trend."""
    finding = await _trend_finding(station)
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "finding-trend-vr", 1280, 760)
    page = client.page
    message = next(m for m in station.running.relay.inspection.captures.recent if m["id"] == finding.id)
    drawn = """async ([message, withTrend]) => {
        const { FindingCard } = await import('/src/view/finding_card.js');
        const id = message.id;
        const shown = withTrend ? message : { ...message, trend: null };
        const review = { selected: id, version: 1, proposal: null, imageAction: 'region', outline: () => null,
                         hint: () => '' };
        const card = new FindingCard(null);
        card.update(review, { findings: new Map([[id, shown]]) }, { operator: true, presenting: true, hover: null });
        const { x, y, w, h } = card.layout.trend;
        const pixels = card.plane.canvas.getContext('2d').getImageData(x, y, w, h).data;
        const count = { red: 0, blue: 0 };
        for (let i = 0; i < pixels.length; i += 4) {
          const [r, g, b] = [pixels[i], pixels[i + 1], pixels[i + 2]];
          if (r > 200 && g < 140 && b < 130) count.red++;  // the threshold, #ff6b5e
          if (b > 200 && r < 170 && g > 150) count.blue++;  // the readings, #8ab4ff
        }
        const png = card.plane.canvas.toDataURL();
        card.dispose();
        return { ...count, png };
    }"""
    with_trend = await page.evaluate(drawn, [message, True])
    without = await page.evaluate(drawn, [message, False])
    ARTIFACTS.mkdir(exist_ok=True)  # the card as drawn, to look at
    (ARTIFACTS / "finding-trend-vr-card.png").write_bytes(base64.b64decode(with_trend.pop("png").split(",", 1)[1]))
    without.pop("png")
    assert with_trend["red"] > 200 and with_trend["blue"] > 300, with_trend
    assert without == {"red": 0, "blue": 0}, without
    assert not client.errors, client.errors
