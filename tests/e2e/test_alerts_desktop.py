"""The desktop's alerts list (issue 30, item 2): an alert the relay raises appears above the findings with a count
badge, and its Acknowledge button sends alert/ack under the page's operator name; the alert then leaves the list."""

from __future__ import annotations

import asyncio

from relay.inspection.records import AlertRecord
from relay.inspection.store import Store
from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station


async def test_an_alert_is_acknowledged_from_the_desktop_list(station: Station, open_client: OpenClient) -> None:
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "alerts", 1280, 760, operator="Tess")
    page = client.page
    inspection = station.running.relay.inspection
    alert = inspection.raise_alert(
        "threshold", "Past its limit at Spill (robot1): gas 698.2 ppm (over 400 ppm)", robot="robot1",
        severity="critical",
    )  # fmt: skip
    item = f"#findings li[data-alert='{alert.id}']"
    await page.wait_for_selector(item, timeout=30_000)
    assert await page.inner_text("#findings .badge") == "1"
    assert "gas 698.2 ppm" in await page.inner_text(item)
    await page.click(f"#findings button[data-ack='{alert.id}']")
    await page.wait_for_selector(item, state="detached", timeout=30_000)
    assert await page.locator("#findings .badge").count() == 0
    store = inspection.store
    assert store is not None

    def stored() -> AlertRecord | None:  # on a connection of the test's own: the relay's is its store thread's
        with Store.open(store.name, store.images) as own:
            return own.alert(alert.id)

    acknowledged = await asyncio.to_thread(stored)
    assert acknowledged is not None and acknowledged.acked_by == "Tess"
