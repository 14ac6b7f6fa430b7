"""The plumbing room's valve wheel (relay/sim/valve.py): a gripper that closes on its rim and turns it a quarter turn
shuts the leak, and the humidity near it falls back to its baseline; a gripper closed away from the rim, or opened,
turns nothing. Pure: tips and times are given by hand."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from relay.arm.kinematics import forward
from relay.arm.rules import ArmBounds
from relay.arm.sim_arm import SimArm
from relay.arm.srdf import load_group_states
from relay.backends.sim import SimBackend
from relay.cli.options import Options
from relay.config import FleetConfig, Valve, load_config
from relay.errors import ConfigError
from relay.fleet.events import Event, ValveEvent
from relay.sim.hazards import HazardSource, SensorField
from relay.sim.kinematics import DiffDriveState
from relay.sim.valve import GRASP, QUARTER_TURN, ValveWheel, tip_in_map
from relay.sim.world import SimWorld
from relay.station.core import Relay
from tests.helpers.arm import omx, tb3_manipulation
from tests.helpers.station import Clock, FakeBackend, Station
from tests.helpers.waiting import wait_until

#: Facing south (its axis along -y), 0.2 m up, a 5 cm rim, as robots.yaml's.
VALVE = Valve(x=15.6, y=7.25, z=0.2, hazard="humidity", yaw=-math.pi / 2, radius=0.05, fade=8.0)


def rim(angle: float) -> tuple[float, float, float]:
    """A point of the rim at ``angle`` about the axis (0: to the wheel's right as seen along its axis, then up)."""
    # In the wheel's plane, "side" is (-ay, ax) = (1, 0) for yaw -pi/2: east.
    return VALVE.x + VALVE.radius * math.cos(angle), VALVE.y, VALVE.z + VALVE.radius * math.sin(angle)


def turn(wheel: ValveWheel, start: float, end: float, now: float = 0.0, steps: int = 20) -> bool:
    """Close on the rim at ``start`` and go round to ``end``; whether the wheel was shut."""
    wheel.step(rim(start), False, now)
    shut = wheel.step(rim(start), True, now)
    for k in range(1, steps + 1):
        shut = wheel.step(rim(start + (end - start) * k / steps), True, now + k * 0.05) or shut
    return shut


def test_a_quarter_turn_by_the_rim_shuts_the_valve_either_way() -> None:
    for direction in (1, -1):
        wheel = ValveWheel(VALVE)
        assert not turn(wheel, 0.3, 0.3 + direction * (QUARTER_TURN - 0.1))
        assert wheel.shut_at is None and abs(wheel.turned) == pytest.approx(QUARTER_TURN - 0.1)
        assert turn(wheel, 0.3, 0.3 + direction * 0.2, now=5.0)
        assert wheel.shut_at is not None and wheel.shut_at > 5.0


def test_a_gripper_closed_away_from_the_rim_or_opened_turns_nothing() -> None:
    wheel = ValveWheel(VALVE)
    x, y, z = rim(0.0)
    wheel.step((x + 2 * GRASP, y, z), True, 0.0)  # closed 6 cm off the rim
    for k in range(20):
        wheel.step(rim(0.1 * k), True, 0.05 * k)  # then dragged round it, closed
    assert wheel.turned == 0.0
    wheel.step(rim(0.0), False, 1.0)
    wheel.step(rim(0.0), True, 1.05)  # closed on the rim: held
    assert wheel.held
    wheel.step(rim(0.5), False, 1.1)  # opened: let go, and the open gripper going round turns nothing
    assert not wheel.held
    wheel.step(rim(1.5), True, 1.15)  # closed again there: a new grasp, no turn
    assert wheel.turned == 0.0
    wheel.step((VALVE.x, VALVE.y - 3 * GRASP, VALVE.z), True, 1.2)  # out of the wheel's plane
    assert wheel.turned == 0.0


def test_shutting_it_fades_the_leak_and_only_the_leak() -> None:
    leak = HazardSource("humidity", 15.6, 7.6, 45.0, 1.8)
    elsewhere = HazardSource("humidity", 3.0, 3.0, 45.0, 1.8)
    fields = {"humidity": SensorField("humidity", 40.0, 0.0, (leak, elsewhere))}
    wheel = ValveWheel(VALVE)
    assert wheel.shut(fields, 10.0) is fields
    turn(wheel, 0.0, QUARTER_TURN + 0.05, now=10.0)
    at = wheel.shut_at
    assert at is not None
    assert wheel.shut(fields, at)["humidity"].mean(15.6, 7.6) == pytest.approx(85.0)
    later = wheel.shut(fields, at + 30.0)["humidity"]
    assert later.mean(15.6, 7.6) < 40.0 + 45.0 * math.exp(-30.0 / 8.0) + 1e-9  # under 41: below the warning (70)
    assert later.mean(3.0, 3.0) == pytest.approx(85.0, abs=0.01)


def test_the_tip_in_the_map_turns_with_the_robot() -> None:
    assert tip_in_map((15.6, 6.9, math.pi / 2), (0.3, 0.0, 0.2)) == pytest.approx((15.6, 7.2, 0.2))
    assert np.allclose(tip_in_map((1.0, 2.0, 0.0), (0.1, 0.05, 0.3)), (1.1, 2.05, 0.3))


def test_the_demo_has_the_valve_by_the_leak_and_a_bad_entry_names_its_field(tmp_path: Path) -> None:
    root = Path(__file__).parents[1]
    valve = load_config(root / "robots.yaml").sim.valve
    assert valve is not None and valve.hazard == "humidity"
    assert math.hypot(valve.x - 15.6, valve.y - 7.6) < 1.0
    text = (root / "robots.yaml").read_text().replace("radius: 0.05", "radius: -1")
    (tmp_path / "robots.yaml").write_text(text.replace("scenes/facility.yaml", str(root / "scenes/facility.yaml")))
    with pytest.raises(ConfigError, match=r"sim\.valve\.radius"):
        load_config(tmp_path / "robots.yaml")


def test_robot3s_gripper_turns_the_valve_shut_and_the_humidity_falls_back(fleet_config: FleetConfig) -> None:
    # The simulator's own parts with a clock moved by hand: robot3 in front of the wheel, its arm servoed (twists
    # toward a target, as the VR hand's position loop sends them) onto the rim's top, the gripper closed, then round
    # a quarter of the rim, and opened.
    poses = load_group_states(tb3_manipulation("config", "turtlebot3_manipulation.srdf"))
    spec = next(r.arm for r in fleet_config.robots if r.arm is not None)
    assert spec is not None
    arm = SimArm(omx(), spec.limits, ArmBounds.of(spec), poses, timeout=0.5, positions=(0.0, -1.0, 0.7, 0.3))
    world = SimWorld(fleet_config, lambda *_: None)
    wheel = world.valve
    assert wheel is not None
    valve = wheel.valve
    pose = (valve.x, valve.y - 0.22, math.pi / 2)  # facing north, the wheel 0.22 m ahead
    world.robots["robot3"].state = DiffDriveState(*pose, 0.0, 0.0)
    centre = np.array([0.22, 0.0, valve.z])  # the wheel's centre in the arm's base link (x north, y west)
    now = 0.0

    def tip() -> np.ndarray:
        return forward(arm.model, arm.positions)[:3, 3]

    def gripping() -> bool:
        return arm.joint_state().position[4] < 0.0045

    def go(target: np.ndarray, seconds: float) -> None:
        nonlocal now
        for _ in range(round(seconds / 0.02)):
            now += 0.02
            world.time = now
            assert arm.servo(tuple(3.0 * (target - tip())), (0.0, 0.0, 0.0), now) is None
            arm.step(now)
            wheel.step(tip_in_map(pose, tip()), gripping(), world.time)

    assert arm.gripper("open") is None
    top = centre + np.array([0.0, 0.0, valve.radius])
    go(top, 4.0)
    assert np.linalg.norm(tip() - top) < 0.01
    assert arm.gripper("close") is None
    go(top, 0.5)
    assert wheel.held
    for k in range(1, 21):  # round the rim toward the east (the arm's -y), a quarter turn and a little
        angle = math.pi / 2 + (QUARTER_TURN + 0.1) * k / 20
        go(centre + np.array([0.0, valve.radius * math.cos(angle), valve.radius * math.sin(angle)]), 0.3)
    assert wheel.shut_at is not None, f"turned {wheel.turned:.2f} rad"
    assert arm.gripper("open") is None
    before = dict(world.readings("robot3"))["humidity"]
    world.time = wheel.shut_at + 30.0
    after = np.mean([dict(world.readings("robot3"))["humidity"] for _ in range(20)])
    robot3 = next(r for r in fleet_config.robots if r.name == "robot3")
    warn = next(s.warn_above for s in robot3.sensors if s.name == "humidity")
    assert warn is not None
    assert before > warn and after < warn, (before, after)


def test_the_wheel_reports_its_state_when_it_changes() -> None:
    wheel = ValveWheel(VALVE)
    first = wheel.report()
    assert first == ValveEvent(15.6, 7.25, 0.2, -math.pi / 2, 0.05, 0.0, False, False)
    assert wheel.report() is None  # nothing changed
    wheel.step(rim(0.0), False, 0.0)
    wheel.step(rim(0.0), True, 0.05)
    held = wheel.report()
    assert held is not None and held.held and held.angle == 0.0
    wheel.step(rim(0.005), True, 0.1)  # less than half a degree: not worth a message
    assert wheel.report() is None
    wheel.step(rim(0.3), True, 0.15)
    turned = wheel.report()
    assert turned is not None and turned.angle == pytest.approx(0.3)
    turn(wheel, 0.3, QUARTER_TURN + 0.1, now=1.0)
    shut = wheel.report()
    assert shut is not None and shut.shut and not shut.held and shut.angle >= QUARTER_TURN


async def test_the_valve_reaches_every_client_and_one_that_connects_later(fleet_config: FleetConfig) -> None:
    relay = Relay(fleet_config, Options(), backend_factory=lambda config, sink, _: FakeBackend(config, sink))
    station = Station(relay, relay.backend, Clock())  # type: ignore[arg-type]
    _, early = station.connect(role="viewer")
    relay.on_event(ValveEvent(15.6, 7.25, 0.2, -math.pi / 2, 0.05, 0.7854, True, False))
    await station.settle()
    expected = {
        "identifier": "valve", "x": 15.6, "y": 7.25, "z": 0.2, "yaw": -1.5708, "radius": 0.05, "angle": 0.785,
        "held": True, "shut": False,
    }  # fmt: skip
    assert early.of("valve") == [expected]
    _, late = station.connect(role="viewer")
    await station.settle()
    assert late.of("valve") == [expected]
    assert [m["identifier"] for m in late.texts][:2] == ["hello", "operators"]  # after hello, as state
    await relay.stop()


async def test_the_sim_backend_reports_its_valve_at_start(fleet_config: FleetConfig) -> None:
    events: list[Event] = []
    backend = SimBackend(fleet_config, events.append)
    await backend.start()
    try:
        await wait_until(lambda: any(isinstance(e, ValveEvent) for e in events), 10, "the valve's first report")
    finally:
        await backend.stop()
    valve = next(e for e in events if isinstance(e, ValveEvent))
    assert (valve.x, valve.y, valve.angle, valve.held, valve.shut) == (15.6, 7.25, 0.0, False, False)
