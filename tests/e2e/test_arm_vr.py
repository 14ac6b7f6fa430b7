"""robot3's arm by the hand in VR (issue #32), on IWER's emulated Quest 3: with robot3 selected, a squeeze of the
right controller at the arm's gripper takes it, the gripper follows the controller's motion (half of it) while the
squeeze is held (a haptic tick says it was taken; all of it with the menu's Hand 1:1), and pitches with it, the
gripper's camera shows beside it meanwhile, and letting go stops the arm and that camera's stream.
Needs the shared data (turtlebot3_manipulation_description)."""

from __future__ import annotations

import math
import time
from typing import Any

from relay.arm.kinematics import forward
from tests.helpers.arm import tb3_manipulation
from tests.helpers.browser import OpenClient, Station, wait_until
from tests.helpers.xr import button, enter_vr, hold_at, press_menu_button, set_menu, turn


def tip_height(station: Station) -> float:
    backend: Any = station.running.relay.backend
    arm = backend._arms.arms["robot3"]
    return float(forward(arm.model, arm.positions)[2, 3])


def gripper_pitch(station: Station) -> float:
    """How far the gripper's axis points below the horizontal (rad)."""
    backend: Any = station.running.relay.backend
    arm = backend._arms.arms["robot3"]
    return -math.asin(float(forward(arm.model, arm.positions)[2, 0]))


async def test_a_squeeze_at_the_gripper_takes_robot3s_arm_and_it_follows_the_hand(
    station: Station, open_client: OpenClient
) -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")
    client = await enter_vr(open_client, station.url)
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot3")
    await client.wait("s.menu.selected === 'robot3'")
    await set_menu(client, False)
    tip = await client.wait("s.arms.robot3 && s.arms.robot3.drawn && s.arms.robot3.tip", 20)
    held = await hold_at(client, tip)
    await client.frames(3)
    felt = (await client.state())["xr"]["haptics"]["count"]
    await button(client, "right", "squeeze", 1)
    await client.wait("s.arms.robot3.held", 10)
    # A haptic tick in the hand that took it.
    tick = await client.wait("s.xr.haptics.count > arg && s.xr.haptics", 10, felt)
    assert (tick["hand"], tick["intensity"], tick["ms"]) == ("right", 0.5, 40), tick
    start = tip_height(station)
    # The hand 10 cm up: the gripper goes 5 cm up.
    await client.page.evaluate("(p) => window.__iwer.controllers.right.position.set(p[0], p[1] + 0.1, p[2])", held)
    await wait_until(lambda: tip_height(station) > start + 0.03, 30, "robot3's gripper following the hand up")
    # The gripper's own camera (robots.yaml arm.camera), streamed and shown beside it while the hand holds the arm.
    camera = await client.wait("s.arms.robot3.gripperCamera.frames > 0 && s.arms.robot3.gripperCamera", 30)
    assert camera["visible"] and camera["identifier"] == "robot3/camera/gripper", camera
    await client.shot("00-gripper-camera")
    # The hand pitches its fingers down 0.6 rad (about the robot's left, in the twin: the map's y turned by its yaw):
    # the gripper pitches down too, where the tip stays (the relay fits the turn in what its position leaves free).
    pitch = gripper_pitch(station)
    pose = station.running.relay.fleet.snapshot(time.monotonic())["robot3"]["pose"]
    assert pose is not None
    yaw = pose["yaw"]
    left = [-math.sin(yaw), 0.0, -math.cos(yaw)]  # the map's (-sin, cos, 0) in the twin's frame (x, up, -y)
    await turn(client, left, 0.6)
    await wait_until(lambda: gripper_pitch(station) > pitch + 0.1, 30, "robot3's gripper pitching down with the hand")
    # Hand 1:1 (the menu's Options row, pressed with the other hand): the gripper follows the whole of the hand's
    # motion from where it is (taken again there: no jump), 2.5 cm up for 2.5 cm (half of it would be 1.25; near the
    # top of its reach, 4 cm brought the elbow within its margin of its limit, refused).
    await set_menu(client, True)
    await press_menu_button(client, "opt:hand", hand="left")
    await client.wait("s.menu.buttons.some((b) => b.id === 'opt:hand' && b.active)", 10)
    await set_menu(client, False)
    await client.frames(3)
    before = tip_height(station)
    await client.page.evaluate("(p) => window.__iwer.controllers.right.position.set(p[0], p[1] + 0.125, p[2])", held)
    await wait_until(lambda: tip_height(station) > before + 0.02, 30, "robot3's gripper following the hand 1:1")
    await button(client, "right", "squeeze", 0)
    await client.wait("!s.arms.robot3.held && !s.arms.robot3.gripperCamera.visible", 10)
    backend: Any = station.running.relay.backend
    streams = backend.cameras._streams
    await wait_until(lambda: ("robot3", "gripper") not in streams, 10, "the gripper's stream stopped on letting go")
    await client.frames(3)
    after = tip_height(station)
    await client.frames(6)
    assert abs(tip_height(station) - after) < 0.003, "the arm went on moving after the hand let go"
    assert tip_height(station) < before + 0.035, "the gripper went further than the hand's motion"
    await client.shot("01-arm-by-hand")
