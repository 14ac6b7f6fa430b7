"""The sim backend's arms: robot3 of the demo carries ROBOTIS's OpenManipulator-X (the shared data) and publishes its
joints; without the shared data it runs without its arm and says why; every stop stops the arm, an estop latches it."""

from __future__ import annotations

import asyncio
import dataclasses
from pathlib import Path

import cv2
import numpy as np
import pytest

from relay.arm.fleet_arms import load_fleet_arms
from relay.backends.sim import SimBackend
from relay.cli.options import Options
from relay.config import FleetConfig, load_config
from relay.errors import CommandRejected, ConfigError
from relay.fleet.events import Event, JointStateEvent
from relay.sim.arms import SimArms
from relay.sim.camera import embree_available
from relay.station.core import Relay
from relay.twin.urdf.errors import RobotModelError
from tests.helpers.arm import tb3_manipulation
from tests.helpers.station import Clock, FakeBackend, Station

ARM_JOINTS = ("joint1", "joint2", "joint3", "joint4")
HOME = (0.0, -1.0, 0.7, 0.3)  # turtlebot3_manipulation.srdf's group state "home"


def without_shared_data(config: FleetConfig, tmp_path: Path) -> FleetConfig:
    """The demo fleet as a fresh clone sees it: robot3's arm files are not there."""
    robots = []
    for robot in config.robots:
        if robot.arm is not None:
            absent = tmp_path / "no-shared-data" / "turtlebot3_manipulation.urdf"
            robot = dataclasses.replace(robot, arm=dataclasses.replace(robot.arm, urdf=absent))
        robots.append(robot)
    return dataclasses.replace(config, robots=tuple(robots))


def test_the_demo_gives_robot3_an_optional_arm(fleet_config: FleetConfig) -> None:
    arms = {r.name: r.arm for r in fleet_config.robots if r.arm is not None}
    assert list(arms) == ["robot3"]
    arm = arms["robot3"]
    assert arm.optional and arm.urdf is not None and arm.srdf is not None
    assert arm.urdf.parts[-3:-1] == ("robot", "turtlebot3_manipulation_description")


def test_without_the_shared_data_robot3_runs_without_its_arm_and_says_why(
    fleet_config: FleetConfig, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    config = without_shared_data(fleet_config, tmp_path)
    loaded = load_fleet_arms(config.robots)
    assert loaded.arms == {}
    health = loaded.health()
    assert list(health) == ["robot3"] and "runs without its arm: no such file" in health["robot3"]
    assert "no-shared-data" in caplog.text
    arms = SimArms({r.name: r for r in config.robots}, loaded, timeout=0.5)
    with pytest.raises(CommandRejected) as refused:
        arms.arm("robot3", "robot3/arm/twist")
    assert refused.value.code == "no_arm" and "runs without its arm" in refused.value.message


def test_a_required_arm_whose_files_are_absent_stops_the_start(fleet_config: FleetConfig, tmp_path: Path) -> None:
    config = without_shared_data(fleet_config, tmp_path)
    required = [
        dataclasses.replace(r, arm=dataclasses.replace(r.arm, optional=False)) if r.arm is not None else r
        for r in config.robots
    ]
    with pytest.raises(RobotModelError, match="robot3's arm: no such file"):
        load_fleet_arms(required)


def test_an_optional_arm_entry_may_name_absent_files(tmp_path: Path) -> None:
    text = (Path(__file__).parents[1] / "robots.yaml").read_text()
    text = text.replace("../shared/data/robot/", str(tmp_path / "absent") + "/")
    text = text.replace("scenes/facility.yaml", str(Path(__file__).parents[1] / "scenes" / "facility.yaml"))
    (tmp_path / "robots.yaml").write_text(text)
    config = load_config(tmp_path / "robots.yaml")
    arm = next(r.arm for r in config.robots if r.arm is not None)
    assert arm.urdf is not None and not arm.urdf.exists()
    (tmp_path / "robots.yaml").write_text(text.replace("      optional: true\n", ""))
    with pytest.raises(ConfigError, match=r"arm\.urdf: no such file"):
        load_config(tmp_path / "robots.yaml")


async def test_robot3s_arm_publishes_its_joints_moves_and_stops_with_the_robot(fleet_config: FleetConfig) -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")  # skips, naming the folder, without the shared data
    events: list[Event] = []
    backend = SimBackend(fleet_config, events.append)
    await backend.start()
    try:

        async def joints() -> JointStateEvent:
            """The next joint state of robot3 (the sim publishes them at 20 Hz)."""
            del events[:]
            for _ in range(500):
                await asyncio.sleep(0.01)
                states = [e for e in events if isinstance(e, JointStateEvent) and e.robot == "robot3"]
                if states:
                    return states[-1]
            raise AssertionError("robot3 published no joint state in 5 s")

        state = await joints()
        assert state.names[:5] == (*ARM_JOINTS, "gripper_left_joint")
        assert state.positions[:4] == pytest.approx(HOME)
        assert backend.health() == {"arms": {"robot3": "ready"}}
        assert not any(isinstance(e, JointStateEvent) and e.robot != "robot3" for e in events)

        await backend.send_arm_twist("robot3", (0.0, 0.0, 0.05), (0.0, 0.0, 0.0))  # up, slowly
        moved = False
        for _ in range(20):
            state = await joints()
            moved = moved or state.positions[:4] != pytest.approx(HOME, abs=1e-3)
        assert moved, "the arm did not follow the twist"
        await backend.stop_robot("robot3")  # a take-over, a lease's end: the arm stops with the base
        held = (await joints()).positions
        assert (await joints()).positions == pytest.approx(held)

        await backend.estop_robot("robot3")
        with pytest.raises(CommandRejected) as refused:
            await backend.send_arm_twist("robot3", (0.0, 0.0, 0.05), (0.0, 0.0, 0.0))
        assert refused.value.code == "arm_refused" and "estop latched" in refused.value.message
        backend.release_estop("robot3")
        await backend.send_gripper("robot3", "open", 0.01)
    finally:
        await backend.stop()


async def test_an_arms_joint_state_reaches_every_client_with_its_skeleton(fleet_config: FleetConfig) -> None:
    tb3_manipulation("turtlebot3_manipulation.urdf")
    relay = Relay(fleet_config, Options(), backend_factory=lambda config, sink, _: FakeBackend(config, sink))
    await relay.arms.start()
    station = Station(relay, relay.backend, Clock())  # type: ignore[arg-type]
    _, seen = station.connect(role="viewer")
    names = (*ARM_JOINTS, "gripper_left_joint", "gripper_right_joint")
    relay.on_event(JointStateEvent("robot3", 1.5, names, (*HOME, 0.01, 0.01)))
    relay.on_event(JointStateEvent("robot1", 1.5, names, (*HOME, 0.01, 0.01)))  # no arm: nothing to say
    await station.settle()
    [joints] = seen.of("robot3/joints")
    assert joints["names"] == list(names) and joints["positions"] == [*HOME, 0.01, 0.01]
    points = joints["points"]
    assert len(points) == 6 and points[0] == [0.0, 0.0, 0.0]  # base_link, joint1..4, end_effector_link
    assert points[-1] == pytest.approx([0.0697, 0.0, 0.2935], abs=1e-4)  # the tip at home, as docs/protocol.md shows
    assert joints["gripper"] == [0.01, -0.01]  # the SRDF's open and close: a trigger's travel maps onto them
    assert seen.of("robot1/joints") == []
    await relay.stop()


def test_an_arm_from_robot_description_is_not_read_yet_and_says_so(fleet_config: FleetConfig) -> None:
    robots = [
        dataclasses.replace(r, arm=dataclasses.replace(r.arm, urdf=None)) if r.arm is not None else r
        for r in fleet_config.robots
    ]
    loaded = load_fleet_arms(robots)
    assert loaded.arms == {} and "robot_description" in loaded.health()["robot3"]


async def test_the_gripper_camera_sees_from_the_gripper_and_its_view_moves_with_the_arm(
    fleet_config: FleetConfig,
) -> None:
    """robot3's `gripper` camera (robots.yaml `arm.camera`) is rendered from the arm's tip, looking along the fingers:
    not the base camera's view, and another one once the arm has moved (issue #32, camera on the gripper)."""
    tb3_manipulation("turtlebot3_manipulation.urdf")
    if not embree_available():
        pytest.skip("the simulated camera's renders need Embree (embreex, installed by make setup)")
    backend = SimBackend(fleet_config, lambda event: None)
    await backend.start()
    try:
        arms = backend._arms
        x, y, yaw = backend._pose_of("robot3")
        cx, cy, height, heading, pitch = arms.camera_pose("robot3", (x, y, yaw))
        tip = arms.tip("robot3")
        # At the tip, in the map (robot3 faces north: the arm's x is the map's y).
        assert (cx, cy, height) == pytest.approx((x - tip[1], y + tip[0], tip[2]), abs=1e-6)
        assert abs(heading - yaw) < 0.3 and -1.2 < pitch < 1.2  # the fingers point ahead of the robot
        front = await backend.snapshot("robot3", "front")
        first = await backend.snapshot("robot3", "gripper")
        assert front is not None and first is not None
        assert (first.width, first.height) == (320, 240) and (front.width, front.height) == (480, 480)
        await backend.send_arm_twist("robot3", (0.0, 0.0, 0.1), (0.0, 0.0, 0.0))  # up, until its deadman (0.5 s)
        await asyncio.sleep(1.0)
        await backend.stop_arm("robot3")
        assert arms.camera_pose("robot3", (x, y, yaw))[2] > height + 0.03, "the camera rose with the gripper"
        moved = await backend.snapshot("robot3", "gripper")
        assert moved is not None
        before, after = (cv2.imdecode(np.frombuffer(f.jpeg, np.uint8), cv2.IMREAD_GRAYSCALE) for f in (first, moved))
        assert before is not None and after is not None
        assert float(np.abs(before.astype(int) - after.astype(int)).mean()) > 3.0, "the view did not move"
    finally:
        await backend.stop()
