"""Gaze and pinch (the `transient-pointer` input of Safari on Apple Vision Pro, issue #17) in Chromium with IWER's
emulated headset: IWER has no such source, so helpers.xr.gaze_pinch makes one of IWER's own classes, which the page
receives through the real WebXR paths (inputsourceschange, selectstart, the target ray's pose each frame, select,
selectend, removed). Nothing depends on hover, which that input does not give: each act is one look and one pinch.
The operator looks at the floor ahead and pinches: teleported there. At robot2: selected. At the menu tab: the menu
opens; at Goal: the tool is on. At the floor, pinch, look further along the corridor while pinched, let go: robot2's
goal is where the eyes were, facing that way. Before the fix that came with this test, the first frame of a transient
pointer rayed from the last render's matrix (nowhere), so its pinch selected nothing."""

from __future__ import annotations

import math

from tests.helpers.browser import OpenClient, Station, goal_at_backend
from tests.helpers.xr import GOAL, aim, enter_vr, gaze_pinch, settled_point


async def test_a_look_and_a_pinch_select_a_robot_press_the_menu_and_send_a_goal_where_the_eyes_are(
    station: Station, open_client: OpenClient
) -> None:
    client = await enter_vr(open_client, station.url)
    for hand in ("left", "right"):
        await aim(client, hand, [0.0, -5.0, 0.0])  # the controllers lie on the floor, pointing at nothing
    # A teleport: the eyes on the floor halfway between the two nearest robots, where nothing is to select (VR starts
    # facing the robots: the floor 2.5 m ahead had robot1's label on the ray); the pinch's release lands the operator
    # there (a straight ray: where the eyes were).
    s = await client.state()
    eye = s["eye"]
    near = sorted((p for p in (r["position"] for r in s["robots"].values())), key=lambda p: math.dist(p, eye))[:2]
    ahead = [(near[0][0] + near[1][0]) / 2, 0.0, (near[0][2] + near[1][2]) / 2]
    assert all(math.dist(ahead, r["position"]) > 1.0 for r in s["robots"].values()), (ahead, s["robots"])
    await gaze_pinch(client, ahead)
    s = await client.wait("Math.hypot(s.eye[0] - arg[0], s.eye[2] - arg[2]) > 2 && s", 10, eye)
    assert math.hypot(s["eye"][0] - ahead[0], s["eye"][2] - ahead[2]) < 0.05, (s["eye"], ahead)
    # A robot: the eyes on robot2's body (as drawn: a 14 cm tall TurtleBot, its middle).
    drawn = (await client.state())["robots"]["robot2"]["position"]
    body = [drawn[0], drawn[1] + 0.07, drawn[2]]
    await gaze_pinch(client, body)
    s = await client.wait("s.menu.selected === 'robot2' && s", 10)
    assert not s["menu"]["open"]
    # The menu: its tab, the Goal button, Close; each a look and a pinch.
    await gaze_pinch(client, await settled_point(client, "s.menu.tab"))
    await gaze_pinch(client, await settled_point(client, "s.menu.open && s.menu.centres['tool:goal']"))
    await client.wait("s.menu.tool === 'goal'", 10)
    await gaze_pinch(client, await settled_point(client, "s.menu.open && s.menu.centres['menu:close']"))
    await client.wait("!s.menu.open", 10)
    # A goal: the eyes on the corridor's floor, pinch, look 1.5 m further east along it while pinched (the heading),
    # let go.
    gx, gy = GOAL
    floor = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToScene(x, y, 0)", [gx, gy])
    east = await client.page.evaluate("([x, y]) => window.__xrRelay.mapToScene(x, y, 0)", [gx + 1.5, gy])
    await gaze_pinch(client, floor, drag_to=east)
    await client.wait("s.goal.sent === 1", 10)
    robot, sx, sy, syaw = await goal_at_backend(station, lambda: gaze_pinch(client, floor, drag_to=east))
    assert robot == "robot2"
    # Where the eyes were: a straight ray, not an arc thrown from the head (which would land metres further).
    assert math.hypot(sx - gx, sy - gy) < 0.15, (sx, sy)
    assert syaw is not None and abs(syaw) < 0.2, syaw
    await client.shot("gaze-pinch-goal")
    s = await client.state()
    assert all(v is None for k, v in s["xr"]["hover"].items() if k not in ("left", "right")), "the pointer is gone"
    assert client.errors == [], client.errors
