"""E-STOP with hands (issue #31, finding 3), in Chromium with IWER's emulated hand tracking (no controllers): the wrist
panel and its E-STOP ride on the left hand and are drawn there (before, they stayed unseen where a controller had
been, and a pinch at that spot still fired them); a palm turned up shows a red E-STOP that the other index presses;
a fist held closed stops the fleet, a red ring filling around it meanwhile. IWER records no fist: the test loads
the one made from IWER's own `point` pose (xr_client/test/fixtures/hand_poses.js)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator

from tests.conftest import ROOT
from tests.helpers.browser import Client, OpenClient, Station, fixture, wait_until
from tests.helpers.xr import HAND_ORIGIN, aim, enter_vr, hand
from tests.wsclient import TestClient

ROBOTS = ("robot1", "robot2", "robot3")
FIST_JSON = "import('./test/fixtures/hand_poses.js').then((m) => process.stdout.write(JSON.stringify(m.fistHandPose)))"
#: IWER's hand poses live in one object both hands share (its oculusHandConfig.poses): a `fist` added there is a
#: pose either hand can take (`poseId`), interpolated with the pinch as IWER does for its own.
INSTALL_FIST = """async (pose) => {
  const iwer = await import('iwer');
  window.__iwer.hands.left[iwer.P_HAND_INPUT].poses.fist = pose;
}"""


def latched(station: Station) -> list[str]:
    return [r for r in ROBOTS if station.status(r)["estopped"]]


@fixture
async def reset() -> AsyncIterator[object]:
    """Lifts the fleet's E-STOP as another operator would, between the checks of one test."""
    clients: list[TestClient] = []

    async def reset_(station: Station) -> None:
        other = await TestClient.open(station.running.ws_url)
        clients.append(other)
        await other.hello()
        assert (await other.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"
        await wait_until(lambda: latched(station) == [], 5, "released")

    yield reset_
    for other in clients:
        await other.close()


async def hands_vr(open_client: OpenClient, station: Station) -> Client:
    client = await enter_vr(open_client, station.url)
    await client.page.evaluate("window.__iwer.primaryInputMode = 'hand'")
    await hand(client.page, "left", HAND_ORIGIN["left"])
    await hand(client.page, "right", [0.3, 0.9, 0.2])  # low at the side, out of the way
    await client.frames(3)
    return client


async def touch(client: Client, key: str, start: list[float]) -> None:
    """Move the right hand until its index tip is on a button (``s.hands[key]``), by what separates them (the rig's
    turn undone: hands move in IWER's reference space)."""
    position = start
    for _ in range(5):
        s = await client.state()
        if s["hands"][key] is None:
            raise AssertionError(f"no {key}: {s['hands']}")
        gap = await client.page.evaluate(
            """async ([button, tip]) => {
                const THREE = await import('three');
                const rig = new THREE.Quaternion(...window.__xrRelay.state.rig.quaternion).invert();
                return new THREE.Vector3(...button).sub(new THREE.Vector3(...tip)).applyQuaternion(rig).toArray();
            }""",
            [s["hands"][key], s["hands"]["tips"]["right"]],
        )
        if sum(g * g for g in gap) ** 0.5 < 0.01:
            return
        position = [p + g for p, g in zip(position, gap, strict=True)]
        await hand(client.page, "right", position)
        await client.frames(3)


async def test_the_wrist_estop_rides_on_the_hand_drawn_and_a_pinch_on_it_stops_the_fleet(
    station: Station, open_client: OpenClient, reset: object
) -> None:
    client = await hands_vr(open_client, station)
    await hand(client.page, "left", [-0.05, 1.3, -0.45])  # raised in front, the back of the wrist to the eyes
    # The hand moves on the next XR frame, and the panel's world position is the last drawn frame's: read it after.
    await client.frames(3)
    s = await client.wait("s.estop.wristDrawn && s.estop.points.wrist && s", 10)
    # On the left hand: within a hand's length of its index tip (it stayed at the controller's old place before).
    wrist, tip = s["estop"]["points"]["wrist"], s["hands"]["tips"]["left"]
    assert sum((a - b) ** 2 for a, b in zip(wrist, tip, strict=True)) ** 0.5 < 0.3, (wrist, tip)
    await client.shot("hands-wrist-estop", "vr-hands-wrist.png")
    # The right hand's ray on it, a pinch: every robot stops.
    await aim(client, "right", wrist, "hand")
    await client.wait("s.xr.hover.right === 'estop'", 10)
    await client.page.evaluate("window.__iwer.hands.right.updatePinchValue(1)")
    await wait_until(lambda: latched(station) == list(ROBOTS), 10, "every robot latched from the wrist")
    await client.page.evaluate("window.__iwer.hands.right.updatePinchValue(0)")
    await client.wait("s.estop.vr", 5)
    await reset(station)  # type: ignore[operator]
    assert client.errors == [], client.errors


async def test_a_palm_turned_up_shows_a_red_estop_that_the_other_index_presses(
    station: Station, open_client: OpenClient, reset: object
) -> None:
    client = await hands_vr(open_client, station)
    await hand(client.page, "left", [-0.05, 1.35, -0.4])  # in front, in view
    await client.page.evaluate("window.__iwer.hands.left.quaternion.set(0, 0, 1, 0)")  # palm up
    s = await client.wait("s.hands.estopButton && s.hands.button && s", 10)
    await client.shot("hands-palm-estop", "vr-hands-estop.png")
    assert latched(station) == [] and not s["menu"]["open"], "showing the buttons presses nothing"
    # The two buttons are far enough apart that a fingertip on one is not on the other.
    apart = sum((a - b) ** 2 for a, b in zip(s["hands"]["estopButton"], s["hands"]["button"], strict=True)) ** 0.5
    assert apart > 0.06, apart
    await touch(client, "estopButton", [0.3, 0.9, 0.2])
    await wait_until(lambda: latched(station) == list(ROBOTS), 10, "every robot latched by the palm's E-STOP")
    s = await client.wait("s.hands.estopPresses === 1 && s", 5)
    await client.frames(5)  # the finger stays on it: one press
    s = await client.state()
    assert s["hands"]["estopPresses"] == 1 and s["hands"]["menuPresses"] == 0 and not s["menu"]["open"], s["hands"]
    await reset(station)  # type: ignore[operator]
    assert client.errors == [], client.errors


async def test_a_fist_held_closed_stops_the_fleet_once_with_a_ring_filling(
    station: Station, open_client: OpenClient
) -> None:
    node = await asyncio.create_subprocess_exec(
        "node", "--input-type=module", "-e", FIST_JSON, cwd=ROOT / "xr_client", stdout=asyncio.subprocess.PIPE
    )
    out, _ = await node.communicate()
    assert node.returncode == 0
    fist = json.loads(out)
    client = await hands_vr(open_client, station)
    await client.page.evaluate(INSTALL_FIST, fist)
    await hand(client.page, "right", [0.1, 1.4, -0.4])  # in front, in view
    await client.frames(3)
    assert (await client.state())["hands"]["ring"] is None
    await client.page.evaluate("window.__iwer.hands.right.poseId = 'fist'")
    # The fist closes: the ring shows, filling; the stop comes when it is full.
    s = await client.wait("s.hands.ring !== null && s", 10)
    assert s["hands"]["fistStops"] == 0, "not at once"
    await client.shot("hands-fist-ring")
    await wait_until(lambda: latched(station) == list(ROBOTS), 10, "every robot latched by the fist")
    s = await client.wait("s.hands.fistStops === 1 && s", 5)
    # Held on: once. Opened, the ring goes.
    await client.frames(6)
    assert (await client.state())["hands"]["fistStops"] == 1
    await client.page.evaluate("window.__iwer.hands.right.poseId = 'default'")
    await client.wait("s.hands.ring === null && !s.hands.fists.right", 10)
    assert client.errors == [], client.errors
