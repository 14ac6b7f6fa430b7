"""Issue #32's "Done when", in the headset (IWER's emulated Quest 3): the operator selects robot3, goes to the plumbing
room by the overview table, sends robot3 to the valve with the goal arc (dragged north for its heading), takes the
gripper by a squeeze, opens and closes it with the trigger, turns the valve's wheel a quarter turn by moving the hand
round its rim, and lets go; the humidity robot3 reads beside the leak falls below its warning within 30 s. The wheel
is drawn in the twin at robots.yaml's sim.valve, turning as the relay reports it. Needs the shared data
(turtlebot3_manipulation_description): skipped without it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from playwright.async_api import TimeoutError as PlaywrightTimeout

from relay.arm.kinematics import forward
from relay.config import Valve
from relay.sim.kinematics import DiffDriveState
from relay.sim.valve import QUARTER_TURN, tip_in_map
from tests.helpers.arm import tb3_manipulation
from tests.helpers.browser import (
    HEADSET,
    SOFTWARE_GL,
    VR_VIEW,
    Client,
    OpenClient,
    Station,
    goal_at_backend,
    wait_until,
)
from tests.helpers.xr import aim, aim_arc, button, click, hold_at, present, press_menu_button, set_menu

#: Where robot3 stands to turn the valve (docs/configuration.md, the demo fleet): 0.22 m south of the wheel, facing
#: north; the arm reaches the wheel's rim from there (tests/test_sim_valve.py servos it so).
STANDOFF = 0.22
#: Where the operator watches from: the plumbing room's floor, south-east of the valve, a metre from it.
WATCH = (16.3, 6.4)


#: Where the operator crouches to watch: south-east of the wheel, its face seen aslant, robot3's arm in front.
CROUCH = (0.3, -0.34, 0.3)

#: The emulated headset turned to look at a world point: yaw, then pitch, no roll.
_LOOK_AT = """
async ([world]) => {
  const THREE = await import('three');
  const s = window.__xrRelay.state;
  const rigRotation = new THREE.Quaternion(...s.rig.quaternion);
  const d = new THREE.Vector3(...world).sub(new THREE.Vector3(...s.eye)).normalize()
    .applyQuaternion(rigRotation.invert());
  const q = new THREE.Quaternion().setFromEuler(new THREE.Euler(Math.asin(d.y), Math.atan2(-d.x, -d.z), 0, 'YXZ'));
  window.__iwer.quaternion.set(q.x, q.y, q.z, q.w);
}
"""


def backend_of(station: Station) -> Any:
    return station.running.relay.backend


def tip_on_map(station: Station) -> np.ndarray:
    """robot3's gripper, where the simulator has it (map frame)."""
    backend = backend_of(station)
    arm = backend._arms.arms["robot3"]
    state = backend.world.robots["robot3"].state
    return np.array(tip_in_map((state.x, state.y, state.yaw), forward(arm.model, arm.positions)[:3, 3]))


async def scene_point(client: Client, p: Any) -> np.ndarray:
    return np.array(await client.page.evaluate("(p) => window.__xrRelay.mapToScene(p[0], p[1], p[2])", list(p)))


async def humidity(client: Client) -> float:
    value: float = await client.wait(
        "(s.panel.sensors.find((x) => x.name === 'humidity') || {}).value != null"
        " && s.panel.sensors.find((x) => x.name === 'humidity').value",
        20,
    )
    return value


async def point_at_table(client: Client, x: float, y: float) -> None:
    point = await client.page.evaluate("([x, y]) => window.__xrRelay.overviewPoint(x, y)", [x, y])
    await aim(client, "right", point)
    await client.wait("s.xr.hover.right === 'wim'", 10)


async def send_robot3_to_the_valve(client: Client, station: Station, valve: Valve) -> None:
    """From where the operator watches: Goal on, the arc on the floor in front of the wheel, dragged north."""
    await set_menu(client, True)
    await press_menu_button(client, "tool:goal")
    await client.wait("s.menu.tool === 'goal'")
    await set_menu(client, False)
    # The follower stops within 10 cm of its goal, coming from the south: the goal a little past the standoff.
    spot = (valve.x, valve.y - STANDOFF + 0.08)
    target = (await scene_point(client, (*spot, 0.0))).tolist()
    north = (await scene_point(client, (spot[0], spot[1] + 1.2, 0.0))).tolist()

    async def place() -> None:
        await aim_arc(client, "right", target)
        await client.wait(
            "s.goal.hover && Math.hypot(s.goal.hover.x - arg[0], s.goal.hover.y - arg[1]) < 0.15", 10, spot
        )
        await button(client, "right", "trigger", 1)
        await client.wait("s.goal.pointer === 'placing'")
        await aim_arc(client, "right", north)
        await client.wait(
            "s.goal.marker && s.goal.marker.yaw !== null && Math.abs(s.goal.marker.yaw - Math.PI / 2) < 0.2"
        )
        await button(client, "right", "trigger", 0)

    await place()
    robot, gx, gy, yaw = await goal_at_backend(station, place)
    assert robot == "robot3" and math.hypot(gx - spot[0], gy - spot[1]) < 0.15 and yaw is not None, station.goals
    for attempt in range(2):
        await wait_until(lambda: station.status("robot3")["mode"] == "navigating", 20, "robot3 on its way")
        await wait_until(lambda: station.status("robot3")["mode"] == "idle", 120, "robot3 at the valve")
        if math.dist(station.pose("robot3"), spot) < 0.15:
            break
        # Once (of five runs) robot3 went idle at the plumbing room's door, its goal ended by something this test
        # did not see (no refusal; one zero velocity, when is unknown); the operator sends it again, as one would.
        notice = (await client.state())["notice"]
        assert attempt == 0, (station.pose("robot3"), notice, station.velocities, station.refusals)
        await place()
    await set_menu(client, True)
    await press_menu_button(client, "tool:goal")  # Goal off again: the trigger is the gripper's next
    await client.wait("s.menu.tool !== 'goal'")
    await set_menu(client, False)


def stand_at_the_valve(station: Station, valve: Valve) -> tuple[float, float, float]:
    """The last centimetres: the follower stops anywhere within 10 cm of its goal, the arm reaches the rim only from
    about 0.22 m. Where the goal left robot3 is checked (it drove there), then it stands where an operator's stick
    would have nudged it, through the simulator's own state, as tests/test_sim_valve.py places it."""
    sim = backend_of(station).world.robots["robot3"]
    reached = (float(sim.state.x), float(sim.state.y), float(sim.state.yaw))
    assert math.hypot(reached[0] - valve.x, reached[1] - (valve.y - STANDOFF)) < 0.15, reached
    assert abs(math.remainder(reached[2] - math.pi / 2, math.tau)) < 0.15, reached
    pose = (valve.x, valve.y - STANDOFF, math.pi / 2)
    sim.state = DiffDriveState(*pose, 0.0, 0.0)
    return pose


def rim(valve: Valve, angle: float) -> np.ndarray:
    """A point of the wheel's rim (map frame): ``angle`` about its axis from its right-hand side (seen along the axis),
    toward the top (relay/sim/valve.py)."""
    ax, ay = math.cos(valve.yaw), math.sin(valve.yaw)
    side = np.array([-ay, ax, 0.0])
    return np.array([valve.x, valve.y, valve.z]) + valve.radius * (
        math.cos(angle) * side + math.sin(angle) * np.array([0.0, 0.0, 1.0])
    )


# A drive of 6 m, an arm at 10 cm/s and a headset SwiftShader draws at a few frames a second: over the suite's 300 s
# guard on a loaded machine.
@pytest.mark.heavy
@pytest.mark.timeout(900)
async def test_robot3_turns_the_valve_shut_by_the_operators_hand_and_the_humidity_falls_back(
    station: Station, open_client: OpenClient
) -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")
    valve = station.running.relay.config.sim.valve
    assert valve is not None
    # robot3 drawn with its model (a TurtleBot3, 14 cm tall), not the software renderer's 0.33 m tall stand-in, which
    # hides a wheel 0.22 m ahead of the robot's centre and 0.2 m up.
    client = await present(await open_client(f"{station.url}/?{HEADSET}&{SOFTWARE_GL}&detail=3", "vr", *VR_VIEW))
    await set_menu(client, True)
    await press_menu_button(client, "robot:robot3")
    await client.wait("s.menu.selected === 'robot3'")
    await set_menu(client, False)
    # The wheel is drawn where robots.yaml puts it, before anyone turns it.
    drawn = await client.wait("s.valve && s.valve.drawn && s.valve", 20)
    centre = await scene_point(client, (valve.x, valve.y, valve.z))
    assert np.allclose(drawn["centre"], centre, atol=1e-3) and drawn["angle"] == 0 and not drawn["shut"], drawn
    # To the plumbing room by the overview table, then robot3 to the valve with the goal arc.
    await client.wait("s.overview.visible", 10)
    await point_at_table(client, *WATCH)
    await click(client, "right")
    watch = await scene_point(client, (*WATCH, 0.0))
    await client.wait("Math.hypot(s.eye[0] - arg[0], s.eye[2] - arg[1]) < 0.3", 20, [watch[0], watch[2]])
    await send_robot3_to_the_valve(client, station, valve)
    stand_at_the_valve(station, valve)
    before = await humidity(client)
    robot3 = next(r for r in station.running.relay.config.robots if r.name == "robot3")
    warn = next(s.warn_above for s in robot3.sensors if s.name == "humidity")
    assert warn is not None and before > warn, f"robot3 reads {before} by the leak, its warning is {warn}"
    eye = await scene_point(client, np.array([valve.x, valve.y, valve.z]) + CROUCH)
    await hold_at(client, eye.tolist(), "head")  # the operator crouching beside the valve to watch the gripper
    await client.frames(2)
    watched = await scene_point(client, (valve.x, valve.y - 0.1, valve.z + 0.02))
    await client.page.evaluate(_LOOK_AT, [watched.tolist()])
    await client.frames(3)
    await client.shot("01-robot3-at-the-valve")

    # The hand at the gripper, a squeeze: held, and the trigger at rest opens the gripper.
    tip = await client.wait(
        "s.arms.robot3 && s.arms.robot3.drawn && Math.hypot(...s.arms.robot3.tip.map((v, i) => v - arg[i])) < 0.02"
        " && s.arms.robot3.tip",
        20,
        (await scene_point(client, tip_on_map(station))).tolist(),
    )
    hand0, tip0 = np.array(tip), tip_on_map(station)
    await hold_at(client, hand0.tolist())
    await client.frames(3)
    await button(client, "right", "squeeze", 1)
    await client.wait("s.arms.robot3.held", 10)
    await client.wait("s.arms.robot3.positions[4] > 0.008", 20)  # open (the SRDF's open: 0.01)

    async def tip_to(target: np.ndarray, tolerance: float, what: str) -> None:
        # The gripper follows half the hand's motion from where the squeeze began: the hand goes twice as far.
        hand = hand0 + 2.0 * (await scene_point(client, target) - await scene_point(client, tip0))
        await hold_at(client, hand.tolist())
        await wait_until(lambda: bool(np.linalg.norm(tip_on_map(station) - target) < tolerance), 30, what)

    top = math.pi / 2
    await tip_to(rim(valve, top) + np.array([0.0, 0.0, 0.03]), 0.01, "the gripper over the wheel")
    await tip_to(rim(valve, top), 0.008, "the gripper on the rim's top")
    await button(client, "right", "trigger", 1)  # close it on the rim
    try:
        await client.wait("s.valve.held", 20)
    except PlaywrightTimeout as exc:
        s = await client.state()
        raise AssertionError(f"not held: {s['valve']}, {s['arms']['robot3']}, {station.refusals[-3:]}") from exc
    await client.shot("02-gripper-closed-on-the-rim")
    assert (await client.state())["arms"]["robot3"]["positions"][4] < 0.0045
    # Round the rim toward the east (the wheel's right-hand side seen from robot3), a quarter turn and a little more.
    steps = 12
    for k in range(1, steps + 1):
        angle = top - (QUARTER_TURN + 0.15) * k / steps
        await tip_to(rim(valve, angle), 0.012, f"the gripper {k}/{steps} of the way round")
        if (await client.state())["valve"]["shut"]:
            break
    # Shut, and the wheel drawn at the relay's angle (a valve message read after the last frame is drawn at the next).
    s = await client.wait("s.valve.shut && Math.abs(s.valve.turned - s.valve.angle) < 1e-6 && s", 20)
    assert abs(s["valve"]["angle"]) >= QUARTER_TURN - 0.01, s["valve"]
    await client.wait("!s.voice.toast", 30)  # the view clear of the last notice (a twist a stop overtook)
    await client.frames(3)
    await client.shot("03-valve-shut", "vr-arm-valve.png")
    # Let go: the trigger opens the gripper, the squeeze's end releases the arm, which stops.
    await button(client, "right", "trigger", 0)
    await client.wait("s.arms.robot3.positions[4] > 0.008", 20)
    await button(client, "right", "squeeze", 0)
    await client.wait("!s.arms.robot3.held", 10)
    # The Done-when's 30 s (the leak fades to e^-1 every 8 s once shut: under the warning in about 3 s).
    await client.wait("(s.panel.sensors.find((x) => x.name === 'humidity') || {}).value < arg", 30, warn)
    assert client.errors == [], client.errors
