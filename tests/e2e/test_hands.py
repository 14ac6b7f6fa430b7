"""Hands (issue #17) in Chromium with IWER's emulated hand tracking: with Teleop on, a pinch held and dragged forward
drives the selected robot (the pinch's place is the stick's centre), and releasing the pinch is the deadman: a zero
command at once and nothing after. The relay's side is what is checked."""

from __future__ import annotations

import time

from playwright.async_api import Page

from .conftest import OpenClient, Station, wait_until
from .test_client_vr import enter_vr
from .xr_helpers import teleop_on


async def hand(page: Page, side: str, position: list[float], pinch: float | None = None) -> None:
    """Move one emulated hand (IWER's device space) and, with ``pinch``, close (1) or open (0) it."""
    await page.evaluate(
        "([side, p, pinch]) => { const h = window.__iwer.hands[side]; h.position.set(...p);"
        " if (pinch !== null) h.updatePinchValue(pinch); }",
        [side, position, pinch],
    )


async def test_pinch_drag_drives_the_robot_and_letting_go_stops_it_at_once(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    await teleop_on(client, "robot2")
    await client.page.evaluate("window.__iwer.primaryInputMode = 'hand'")
    await client.frames(3)
    # The hand held low and to the side: its ray on no menu or robot while it pinches.
    start = [0.25, 1.0, -0.3]
    await hand(client.page, "right", start, 1.0)
    await client.wait("s.hands.pinches >= 1 && s.hands.driving", 10)
    pushed = time.monotonic()
    await hand(client.page, "right", [start[0], start[1], start[2] - 0.15])  # 15 cm forward: full speed
    await wait_until(
        lambda: any(lin > 0.3 for _, lin, _ in station.velocities_of("robot2", pushed)), 10, "robot2 driven by a pinch"
    )
    assert all(abs(lin) <= 0.6 + 1e-9 for _, lin, _ in station.velocities_of("robot2", pushed)), "within its limits"
    await client.shot("hand-drive")
    released = time.monotonic()
    await hand(client.page, "right", [start[0], start[1], start[2] - 0.15], 0.0)
    await wait_until(
        lambda: any(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot2", released)),
        5,
        "a zero command on release",
    )
    zero = next(t for t, lin, ang in station.velocities_of("robot2", released) if lin == 0 and ang == 0)
    assert zero - released < 3.0, zero - released
    await client.wait("!s.hands.driving && s.hands.releases >= 1", 5)
    after = time.monotonic()
    await client.frames(3)
    assert all(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot2", after)), "nothing after"
