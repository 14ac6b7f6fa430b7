"""Hands and controllers swapped mid-drive (issue #17) in Chromium with IWER's emulated Quest 3: the operator drives
robot2 with the right stick, then puts the controllers down for hands (IWER's `primaryInputMode = 'hand'`). The
stick that drove is gone: the robot gets a zero command at once, teleop says it stopped and why, in the headset,
and the menu and the selection are as they were."""

from __future__ import annotations

import time

from tests.helpers.browser import OpenClient, Station, wait_until
from tests.helpers.xr import enter_vr, stick, teleop_on


async def test_switching_to_hands_while_driving_stops_the_robot_and_says_so(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    await teleop_on(client, "robot2")
    pushed = time.monotonic()
    await stick(client, "right", 0.0, -1.0)
    await wait_until(
        lambda: any(lin > 0.3 for _, lin, _ in station.velocities_of("robot2", pushed)), 10, "robot2 driven forward"
    )
    switched = time.monotonic()
    await client.page.evaluate("window.__iwer.primaryInputMode = 'hand'")
    await wait_until(
        lambda: any(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot2", switched)),
        5,
        "a zero command after the switch",
    )
    stopped = next(t for t, lin, ang in station.velocities_of("robot2", switched) if lin == 0 and ang == 0)
    # The zero came at once (within a few of the page's software-rendered frames), and nothing drove after it.
    assert stopped - switched < 3.0, stopped - switched
    later = time.monotonic()
    await client.frames(3)
    assert all(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot2", later)), "nothing drives"
    s = await client.wait("s.notice && s.notice.includes('teleop stopped') && s", 10)
    assert s["notice"] == "teleop stopped: input changed to hands", s["notice"]
    assert s["menu"]["selected"] == "robot2", "the selection survives the switch"
    await client.shot("input-switched")
