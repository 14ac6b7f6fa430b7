"""The demo scenario in VR, in Debian's Chromium with IWER's emulated Meta Quest 3: enter VR, open the menu
with the controller button, pick robot2 and Goal by pointing and pulling the trigger, send a goal by
pointing the arc at the floor (drag for the heading), drive with the stick; Robot POV with a snapshot and a
live stream; teleport and snap turn.
Every step waits on a condition (IWER applies input on the next XR frame); screenshots go to
test-artifacts/."""

from __future__ import annotations

import asyncio
import math
import time

import pytest

from tests.helpers.browser import (
    OpenClient,
    Station,
    distance,
    goal_at_backend,
    measure_rate,
    record_timing,
    snapshot_until_uploaded,
    wait_until,
    window_stats,
)
from tests.helpers.xr import GOAL, aim, aim_arc, button, click, enter_vr, press_menu_button, set_menu, stick


async def test_vr_goal_and_teleop(station: Station, open_client: OpenClient) -> None:
    client = await enter_vr(open_client, station.url)
    await client.shot("01-entered")

    # The menu opens with the Y button, in front of the operator.
    await set_menu(client, True)
    await client.frames(3)
    await client.shot("02-menu", "vr-menu.png")
    s = await press_menu_button(client, "robot:robot2")
    await client.wait("s.menu.selected === 'robot2'")
    s = await press_menu_button(client, "tool:goal")
    s = await client.wait("s.menu.tool === 'goal' && s")
    await set_menu(client, False)

    # The goal pointer: an arc to the floor, press for the position, drag north for the heading.
    x, y = GOAL
    target = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToScene(x, y, 0)", [x, y])
    await aim_arc(client, "right", target)
    hover = await client.wait(
        "s.goal.hover && Math.hypot(s.goal.hover.x - arg[0], s.goal.hover.y - arg[1]) < 0.15 && s.goal.hover",
        10,
        [x, y],
    )
    await button(client, "right", "trigger", 1)
    await client.wait("s.goal.pointer === 'placing'")
    # Drag towards the corridor's south wall: the robot is to face south.
    south = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToScene(x, y, 0)", [x, y - 1.5])
    await aim_arc(client, "right", south)
    await client.wait("s.goal.marker && s.goal.marker.yaw !== null && Math.abs(s.goal.marker.yaw + Math.PI / 2) < 0.2")
    await client.shot("03-goal-drag", "vr-goal.png")
    await button(client, "right", "trigger", 0)
    await client.wait("s.goal.sent === 1")

    async def place_again() -> None:
        await aim_arc(client, "right", target)
        await button(client, "right", "trigger", 1)
        await client.wait("s.goal.pointer === 'placing'")
        await aim_arc(client, "right", south)
        await client.wait("s.goal.marker && s.goal.marker.yaw !== null")
        await button(client, "right", "trigger", 0)

    # The relay got that goal, from the hit point (not the operator's position), and robot2 moves.
    robot, gx, gy, gyaw = await goal_at_backend(station, place_again)
    assert robot == "robot2"
    assert math.hypot(gx - hover["x"], gy - hover["y"]) < 1e-3
    assert gyaw is not None and abs(gyaw + math.pi / 2) < 0.2
    # The spy sees the goal before the relay has planned it: wait for the status that follows.
    await wait_until(lambda: station.status("robot2")["mode"] == "navigating", 10, "robot2 navigating")
    status = station.status("robot2")
    assert status["controller"] == (await client.state())["clientId"]
    assert status["goal"] is not None and distance((status["goal"]["x"], status["goal"]["y"]), (gx, gy)) < 1e-3
    start = station.pose("robot2")
    await wait_until(lambda: distance(station.pose("robot2"), start) > 0.3, 15, "robot2 moving")
    await client.wait("s.robots.robot2.position[0] < 8.6", 15)  # drawn moving west in the twin
    await client.shot("04-robot-moving")

    # Teleop: the right stick drives robot2 at 20 Hz within its limits; release sends a zero.
    await set_menu(client, True)
    await press_menu_button(client, "tool:teleop")
    await client.wait("s.menu.tool === 'teleop'")
    await set_menu(client, False)
    before = (await client.state())["commands"]["cmdVel"]
    pushed = time.monotonic()
    await stick(client, "right", 0.0, -1.0)
    await wait_until(
        lambda: any(lin > 0.5 for _, lin, _ in station.velocities_of("robot2", pushed)), 10, "cmd_vel forward"
    )
    me = (await client.state())["clientId"]
    await wait_until(
        lambda: station.status("robot2")["mode"] == "teleop" and station.status("robot2")["controller"] == me,
        5,
        "robot2 in teleop by this client",
    )
    rate = await measure_rate(station, "robot2", 2.0)
    record_timing("vr_teleop_cmd_vel_per_s", {"rate": rate})
    # The exact 20 Hz cadence is pinned by xr_client/test/teleop.test.js and teleop_hold.test.js, and at slow
    # frames by tests/e2e/test_teleop_rate.py; here commands must keep coming faster than the deadman (0.5 s), and
    # not by the frame. A loaded relay reads the commands a stall held back all at once (24.5 in a 2 s window, in a
    # fresh clone's run): twice the cadence is the bound.
    assert 2 <= rate <= 40, f"{rate:.1f} cmd_vel per second; the client sends at 20 Hz"
    assert all(
        abs(lin) <= 0.6 + 1e-9 and abs(ang) <= 1.8 + 1e-9 for _, lin, ang in station.velocities_of("robot2", pushed)
    )
    await client.shot("05-teleop")
    released = time.monotonic()
    await stick(client, "right", 0.0, 0.0)
    await wait_until(
        lambda: any(lin == 0 and ang == 0 for _, lin, ang in station.velocities_of("robot2", released)),
        5,
        "the zero on release",
    )
    s = await client.state()
    assert s["commands"]["zeros"] >= 1 and s["commands"]["cmdVel"] > before
    assert client.errors == [], client.errors


async def test_vr_robot_pov(station: Station, open_client: OpenClient) -> None:
    if station.camera is None:
        pytest.skip("no robot of this fleet has a camera")
    client = await enter_vr(open_client, station.url)
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot2")
    await client.wait("s.menu.selected === 'robot2'")

    # Robot POV: the hemisphere in a neutral space, a snapshot onto the one fixed texture.
    rig_before = (await client.state())["rig"]["position"]
    await set_menu(client, True)
    await press_menu_button(client, "mode:pov")
    await client.wait("s.menu.mode === 'pov' && !s.world && s.pov.visible")
    await snapshot_until_uploaded(client, press=lambda: press_menu_button(client, "camera:snapshot"))
    s = await client.state()
    assert s["pov"]["identifier"] == f"robot2/camera/{station.camera}"
    assert s["pov"]["mipmaps"] is False
    await set_menu(client, False)
    await client.frames(5)
    await client.shot("06-pov-snapshot", "vr-pov.png")

    # Live, with 3 robots moving: JS time per frame, and never a new texture per frame.
    await set_menu(client, True)
    await press_menu_button(client, "camera:live")
    await set_menu(client, False)
    before = await client.state()
    await client.wait("s.pov.uploads >= arg", 30, before["pov"]["uploads"] + 6)
    s = await client.state()
    assert s["textures"] == before["textures"], "a texture was created while streaming"
    record_timing("vr_live", {**window_stats(before["timing"], s["timing"]), "pov": s["pov"], "video": s["video"]})

    # Free Roam returns the operator where they were.
    await set_menu(client, True)
    await press_menu_button(client, "mode:free_roam")
    s = await client.wait("s.menu.mode === 'free_roam' && s.world && s")
    assert s["rig"]["position"] == rig_before
    assert not s["menu"]["live"]
    assert client.errors == [], client.errors


async def test_vr_locomotion(station: Station, open_client: OpenClient) -> None:
    client = await enter_vr(open_client, station.url)
    s = await client.state()
    rig_before, facing = s["rig"]["position"], s["rig"]["yaw"]

    # Locomotion on the left stick: push forward to aim the teleport arc, release to land on its ring;
    # push sideways for a 30 degree snap turn (once per push). The ring 2 m ahead, on the corridor's floor.
    ahead = [rig_before[0] - 2.0 * math.sin(facing), 0.0, rig_before[2] - 2.0 * math.cos(facing)]
    await aim_arc(client, "left", ahead)
    await stick(client, "left", 0.0, -1.0)
    target = await client.wait("Array.isArray(s.xr.teleport) && s.xr.teleport", 10)
    await stick(client, "left", 0.0, 0.0)
    moved = "Math.hypot(s.rig.position[0] - arg[0], s.rig.position[2] - arg[2]) > 1.0 && s"
    s = await client.wait(moved, 10, rig_before)
    await client.shot("07-teleported")
    assert math.dist(s["rig"]["position"], rig_before) > 1.0, (target, s["rig"])
    yaw = s["rig"]["yaw"]
    await stick(client, "left", 1.0, 0.0)
    await client.wait("Math.abs(s.rig.yaw - (arg - Math.PI / 6)) < 1e-6", 10, yaw)
    await client.frames(3)  # held: no second turn
    assert abs((await client.state())["rig"]["yaw"] - (yaw - math.pi / 6)) < 1e-6
    await stick(client, "left", 0.0, 0.0)
    assert client.errors == [], client.errors


async def test_vr_inspection_by_pointing(station: Station, open_client: OpenClient) -> None:
    """The Inspect tool in VR: pick a target's ring, make a target by pointing at the floor, send the picked
    target as robot1's mission from the menu, then open its finding's pin: the card shows the capture, sets the
    status, and marks a region from one point of the image."""
    client = await enter_vr(open_client, station.url)
    await client.wait("s.inspection.targets === 3")
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot1")
    await press_menu_button(client, "tool:inspect")
    await client.wait("s.menu.tool === 'inspect'")
    await set_menu(client, False)
    targets = station.running.relay.inspection.targets
    spill = targets["spill"]

    async def point_and_select(point: list[float], hover: str) -> None:
        await aim(client, "right", point)
        await client.wait("s.xr.hover.right === arg", 20, hover)
        await click(client, "right")

    async def scene(x: float, y: float, z: float) -> list[float]:
        point: list[float] = await client.page.evaluate(
            "([x, y, z]) => window.__xrRelay.mapToScene(x, y, z)", [x, y, z]
        )
        return point

    # The spill's ring, in the room behind the corridor's wall: picked (marks are picked through walls).
    await point_and_select(await scene(spill.x, spill.y, 0.0), "insp:target:spill")
    await client.wait("s.inspection.picked.join() === 'spill'")
    # The corridor's floor: a new target there, named without a keyboard.
    await point_and_select(await scene(6.0, 1.2, 0.0), "insp:floor")
    await wait_until(lambda: "point-4" in targets, 10, "the target made by pointing at the floor")
    assert math.hypot(targets["point-4"].x - 6.0, targets["point-4"].y - 1.2) < 0.3, targets["point-4"]
    await client.wait("s.inspection.targets === 4")
    await client.shot("08-inspect-picked")

    # The menu sends the picked target as robot1's mission.
    await set_menu(client, True)
    await press_menu_button(client, "mission:picked")
    await client.wait("s.inspection.missions.robot1 === 'running' && s.inspection.picked.length === 0", 20)
    await set_menu(client, False)
    finding = await client.wait("s.inspection.findings.find((f) => f.target === 'spill')", 120)
    assert finding["status"] == "anomaly"  # the sim's gas over its threshold at the spill

    # Its pin opens the card with the capture.
    await point_and_select(await scene(finding["x"], finding["y"], 1.25), f"insp:finding:{finding['id']}")
    card = await client.wait("s.inspection.card.visible && s.inspection.card.image && s.inspection.card", 20)
    width, height = card["image"]
    points = await client.page.evaluate("(p) => window.__xrRelay.cardPoints(p)", [width * 0.5, height * 0.55])
    await point_and_select(points["status:needs_review"], "insp:card:status:needs_review")
    await client.wait(
        "s.inspection.findings.some((f) => f.id === arg && f.status === 'needs_review')", 10, finding["id"]
    )
    # A region from one point of the image: the relay's outline is proposed, then accepted.
    await point_and_select(points["pixel"], "insp:image")
    await client.wait("s.inspection.review.proposal", 30)
    # The card's buttons are laid out when it is next drawn: its Accept appears then.
    points = await client.wait(
        "(() => { const p = window.__xrRelay.cardPoints(null); return p['region:accept'] ? p : null; })()", 20
    )
    await client.frames(2)
    await client.shot("09-finding-card", "vr-finding-card.png")
    await point_and_select(points["region:accept"], "insp:card:region:accept")
    await client.wait("s.inspection.findings.some((f) => f.id === arg && f.region)", 10, finding["id"])
    store = station.running.relay.inspection.store
    assert store is not None
    stored = next(f for f in await asyncio.to_thread(store.findings, robot="robot1") if f.id == finding["id"])
    assert stored.status == "needs_review" and stored.region is not None and len(stored.region) >= 3
    await point_and_select(points["card:close"], "insp:card:card:close")
    await client.wait("!s.inspection.card.visible")
    assert client.errors == [], client.errors
