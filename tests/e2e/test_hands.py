"""Hands (issue #17) in Chromium with IWER's emulated hand tracking: with Teleop on, a pinch held and dragged forward
drives the selected robot (the pinch's place is the stick's centre), and releasing the pinch is the deadman: a zero
command at once and nothing after. The relay's side is what is checked."""

from __future__ import annotations

import math
import time

from tests.helpers.browser import OpenClient, Station, wait_until
from tests.helpers.xr import HAND_ORIGIN, aim_arc, enter_vr, hand, teleop_on


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


async def test_point_and_pinch_teleports_where_the_arc_lands(station: Station, open_client: OpenClient) -> None:
    """A hand's ray on the floor (nothing there to select), a pinch: the teleport arc shows while pinched, and letting
    go lands the operator on its ring, as the left stick does with controllers."""
    client = await enter_vr(open_client, station.url)
    await client.page.evaluate("window.__iwer.primaryInputMode = 'hand'")
    await client.frames(3)
    s = await client.state()
    before = s["rig"]["position"]
    await hand(client.page, "left", [-0.3, 0.9, 0.2])  # the other hand down at the side
    yaw = s["rig"]["yaw"]  # 2.5 m ahead along the corridor, where the operator faces
    target = [before[0] - 2.5 * math.sin(yaw), 0.0, before[2] - 2.5 * math.cos(yaw)]
    await aim_arc(client, "right", target, "hand")
    await hand(client.page, "right", HAND_ORIGIN["right"], 1.0)
    shown = await client.wait("Array.isArray(s.xr.teleport) && s.xr.teleport", 10)
    await client.shot("hand-teleport-aim")
    assert (await client.state())["rig"]["position"] == before, "nothing moves while aiming"
    await hand(client.page, "right", HAND_ORIGIN["right"], 0.0)
    s = await client.wait("Math.hypot(s.rig.position[0] - arg[0], s.rig.position[2] - arg[2]) > 1 && s", 10, before)
    # The head lands on the ring (teleportTo keeps the head, not the rig's origin, over the point).
    eye = s["eye"]
    assert math.hypot(eye[0] - shown[0], eye[2] - shown[2]) < 0.05, (eye, shown)
    assert s["xr"]["teleport"] is None
    assert client.errors == [], client.errors


async def test_the_wrist_button_appears_on_a_palm_turned_up_and_the_other_index_opens_the_menu(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    await client.page.evaluate("window.__iwer.primaryInputMode = 'hand'")
    await client.frames(3)
    await hand(client.page, "right", [0.3, 0.9, 0.2])  # out of the way
    await hand(client.page, "left", [-0.1, 1.2, -0.35])
    s = await client.state()
    assert not s["hands"]["wristButton"] and not s["menu"]["open"]
    # The left palm turned up (the hand rolled half a turn about its forward axis): the button shows above the wrist.
    await client.page.evaluate("window.__iwer.hands.left.quaternion.set(0, 0, 1, 0)")
    s = await client.wait("s.hands.wristButton && s", 10)
    await client.shot("wrist-button")
    assert not s["menu"]["open"], "showing the button presses nothing"
    # The right index to the button: move the hand by what separates its fingertip from the button (the rig's turn
    # undone: hands move in the reference space), until it touches; the menu opens once.
    position = [0.3, 0.9, 0.2]
    for _ in range(4):
        s = await client.state()
        if s["menu"]["open"]:
            break
        gap = await client.page.evaluate(
            """async ([button, tip]) => {
                const THREE = await import('three');
                const rig = new THREE.Quaternion(...window.__xrRelay.state.rig.quaternion).invert();
                return new THREE.Vector3(...button).sub(new THREE.Vector3(...tip)).applyQuaternion(rig).toArray();
            }""",
            [s["hands"]["button"], s["hands"]["tips"]["right"]],
        )
        position = [p + g for p, g in zip(position, gap, strict=True)]
        await hand(client.page, "right", position)
        await client.frames(3)
    s = await client.wait("s.menu.open && s", 10)
    assert s["hands"]["menuPresses"] == 1
    await client.frames(5)  # the finger stays on the button: no second toggle
    s = await client.state()
    assert s["menu"]["open"] and s["hands"]["menuPresses"] == 1
    await client.shot("wrist-button-menu")
    assert client.errors == [], client.errors
