"""robot3's arm on the desktop (issue #32): drawn on its robot from the sim's joint states; with robot3 selected, U
lifts the tip while held (arm twists at 20 Hz through the relay's rules) and the arm stops when the key is let go;
] closes the gripper. Needs the shared data (ROBOTIS's turtlebot3_manipulation_description): skipped without it."""

from __future__ import annotations

from typing import Any

from relay.arm.kinematics import forward
from tests.helpers.arm import tb3_manipulation
from tests.helpers.browser import SOFTWARE_GL, OpenClient, Station, wait_until


def tip_height(station: Station) -> float:
    backend: Any = station.running.relay.backend
    arm = backend._arms.arms["robot3"]
    return float(forward(arm.model, arm.positions)[2, 3])


async def test_the_keys_move_robot3s_arm_while_held(station: Station, open_client: OpenClient) -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")
    client = await open_client(f"{station.url}/?{SOFTWARE_GL}", "arm-desktop", 1280, 760)
    page = client.page
    await client.wait("s.arms.robot3 && s.arms.robot3.drawn", 20)
    await page.click('#menu button[data-button="robot:robot3"]')
    await client.wait("s.menu.selected === 'robot3'")
    await page.locator("#viewport canvas").focus()
    start = tip_height(station)
    await page.keyboard.down("KeyU")
    await wait_until(lambda: tip_height(station) > start + 0.02, 15, "robot3's tip lifted 2 cm")
    await page.keyboard.up("KeyU")
    # Let go: one zero twist, and the relay's deadman would stop it anyway within 0.5 s of the last twist. On a loaded
    # machine the page reads the key's release late (a frame of hundreds of ms): the arm stops, then stays stopped.
    heights = [tip_height(station)]

    def still() -> bool:
        heights.append(tip_height(station))
        return len(heights) > 5 and max(heights[-5:]) - min(heights[-5:]) < 0.0005

    await wait_until(still, 10, "robot3's arm standing still after the key was let go")
    held = tip_height(station)
    await page.wait_for_timeout(700)
    assert abs(tip_height(station) - held) < 0.002, "the arm went on moving after the key was let go"
    assert station.running.relay.control.leases.holder("robot3") is not None  # the first key took the free lease
    await page.keyboard.press("BracketRight")
    await client.wait("s.arms.robot3.positions[4] < 0", 15)  # the gripper joint towards the SRDF's close (-0.01)
    # Close enough to see the arm: the wheel zooms toward the point under the cursor.
    x, y = station.pose("robot3")
    px, py = await page.evaluate("([x, y]) => window.__xrRelay.mapToPage(x, y, 0.3)", [x, y])
    await page.mouse.move(px, py)
    for _ in range(6):
        await page.mouse.wheel(0, -400)
        await page.wait_for_timeout(200)
    await page.wait_for_timeout(1000)
    await client.shot("01-arm-lifted")
