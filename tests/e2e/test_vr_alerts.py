"""Alerts in the headset (issue 30, item 2): an alert the relay raises is a row of the VR menu while nobody has
acknowledged it; pointing at its button acknowledges it under the headset operator's name, and the alert leaves the
desktop page's list too."""

from __future__ import annotations

from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station
from tests.helpers.inspection import stored_alert
from tests.helpers.xr import enter_vr, press_menu_button, set_menu


async def test_an_alert_is_a_row_of_the_vr_menu_and_acknowledged_by_pointing(
    station: Station, open_client: OpenClient
) -> None:
    desktop = await open_client(f"{station.url}/?{SOFTWARE_GL}", "alerts-desk", 1280, 760, operator="Dana")
    client = await enter_vr(open_client, station.url)  # the headset operator: Tess
    inspection = station.running.relay.inspection
    older = inspection.raise_alert("schedule_missed", "Schedule nightly missed 1 run: the relay was not running")
    alert = inspection.raise_alert(
        "threshold", "Past its limit at Spill (robot1): gas 698.2 ppm (over 400 ppm)", robot="robot1",
        severity="critical",
    )  # fmt: skip
    await set_menu(client, True)
    row = "s.menu.buttons.filter((b) => b.group === 'alerts').map((b) => b.id).sort().join()"
    await client.wait(f"{row} === arg", 30, ",".join(sorted([f"alert:{alert.id}", f"alert:{older.id}"])))
    await client.frames(2)
    await client.shot("alerts-menu", "vr-alerts-menu.png")
    item = f"#findings li[data-alert='{alert.id}']"
    await desktop.page.wait_for_selector(item, timeout=30_000)

    await press_menu_button(client, f"alert:{alert.id}")
    await client.wait(f"{row} === arg", 30, f"alert:{older.id}")
    await desktop.page.wait_for_selector(item, state="detached", timeout=30_000)
    assert await desktop.page.locator(f"#findings li[data-alert='{older.id}']").count() == 1
    acknowledged = await stored_alert(station.running, alert.id)
    assert acknowledged is not None and acknowledged.acked_by == "Tess"
    assert client.errors == [] and desktop.errors == [], (client.errors, desktop.errors)
