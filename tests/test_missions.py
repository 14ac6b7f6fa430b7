"""Inspection targets and missions: where targets come from, how robots look at them, mission files and requests,
fleet assignment, the checks before a mission starts, and the runner's pause, resume, skip, abort and stops."""

from __future__ import annotations

import asyncio
import math
from pathlib import Path

import pytest

from relay.errors import ConfigError
from relay.fleet.events import NavEvent
from relay.inspection.missions import MissionError, assign, load_mission, resolve, steps_from_wire
from relay.inspection.records import MissionRecord, Step, Target
from relay.inspection.runner import MissionRunner
from relay.inspection.targets import facility_targets, load_targets, standoff
from relay.sim.planner import Planner
from relay.twin.facility import load_facility
from tests.conftest import ROOT

FACILITY = load_facility(ROOT / "scenes" / "facility.yaml")
TARGETS = {t.id: t for t in facility_targets(FACILITY)}


def test_the_demo_hazards_become_the_demo_targets() -> None:
    assert sorted(TARGETS) == ["leak", "panels", "spill"]
    panels = TARGETS["panels"]
    assert (panels.kind, panels.x, panels.y) == ("temperature", 9.0, 9.6)  # three sources, one target
    for target in TARGETS.values():
        x, y, yaw = standoff(target, FACILITY.grid, (9.0, 1.5))
        assert FACILITY.grid.clearance(x, y, 0.35) >= 0.35, target  # free, away from walls
        assert 0.8 <= math.hypot(target.x - x, target.y - y) <= 1.6
        bearing = math.atan2(target.y - y, target.x - x)
        assert abs(math.remainder(bearing - yaw, 2 * math.pi)) < 1e-3  # facing it


def test_a_target_with_a_facing_is_looked_at_along_it() -> None:
    valve = Target("valve", "Valve", "valve", 12.0, 1.5, facing=0.0)  # in the corridor, looked at heading +x
    x, y, yaw = standoff(valve, FACILITY.grid, (15.0, 1.5))  # although the robot comes from the other side
    assert (x, y, yaw) == (11.0, 1.5, 0.0)


def test_targets_file_errors_name_the_line(tmp_path: Path) -> None:
    good = tmp_path / "targets.yaml"
    good.write_text("targets:\n  - {id: valve-3, name: Valve 3, kind: valve, x: 4, y: 5, facing: 90}\n")
    [valve] = load_targets(good)
    assert valve == Target("valve-3", "Valve 3", "valve", 4.0, 5.0, math.pi / 2)
    bad = tmp_path / "bad.yaml"
    bad.write_text("targets:\n  - {id: ok, x: 1, y: 2}\n  - {id: 'no spaces', x: 1, y: 2}\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:3: targets\[1\].id: expected an id"):
        load_targets(bad)


def test_mission_files_and_requests(tmp_path: Path) -> None:
    demo = load_mission(ROOT / "missions" / "demo.yaml")
    assert (demo.name, demo.targets) == ("Demo inspection", ("spill", "panels", "leak"))
    path = tmp_path / "m.yaml"
    steps = "[{inspect: spill}, {goto: {x: 3, y: 1.5}}, {dwell: 2}, {capture: null}]"
    path.write_text(f"robots:\n  - robot: robot1\n    steps: {steps}\n")
    plan = load_mission(path)
    assert plan.robots == (
        ("robot1", (Step("inspect", target="spill"), Step("goto", x=3.0, y=1.5), Step("dwell", seconds=2.0),
                    Step("capture"))),
    )  # fmt: skip
    for text, message in [
        ("robots:\n  - robot: robot1\n    steps: [{fly: 3}]\n", "unknown field"),
        ("targets: []\n", "is empty"),
        ("name: x\n", "either targets"),
        ("targets: [spill\n", "not a YAML mission file"),
        ("\x00\x01binary", "not a YAML mission file"),
    ]:
        path.write_text(text)
        with pytest.raises(MissionError, match=message):
            load_mission(path)
    with pytest.raises(MissionError, match="cannot read"):
        load_mission(tmp_path / "missing.yaml")
    assert steps_from_wire([{"inspect": "spill"}, {"dwell": 1}], "mission") == (
        Step("inspect", target="spill"), Step("dwell", seconds=1.0),
    )  # fmt: skip
    raw: object
    for raw in ([], [{"dwell": -1}], [{"goto": {"x": float("nan"), "y": 0}}], [{"inspect": "../x"}], "spill", [{}]):
        with pytest.raises(MissionError):
            steps_from_wire(raw, "mission")


def test_fleet_assignment_is_nearest_first_and_spreads_the_work() -> None:
    robots = {"robot1": (3.0, 1.5), "robot2": (9.0, 1.5), "robot3": (15.0, 1.5)}
    assert assign(["spill", "panels", "leak"], robots, TARGETS) == {
        "robot1": ["spill"], "robot2": ["panels"], "robot3": ["leak"],
    }  # fmt: skip
    # One robot free: it does them all, nearest first from where it stands.
    assert assign(["leak", "spill", "panels"], {"robot3": (15.0, 1.5)}, TARGETS) == {
        "robot3": ["leak", "panels", "spill"]
    }
    with pytest.raises(MissionError, match="no robot is free"):
        assign(["spill"], {}, TARGETS)


def test_every_step_is_checked_before_a_mission_starts() -> None:
    planner = Planner(FACILITY.grid, 0.25)
    steps = [Step("inspect", target="spill"), Step("dwell", seconds=1.0), Step("goto", x=3.0, y=1.5)]
    points = resolve("robot1", steps, TARGETS, (3.0, 1.5), FACILITY.grid, planner)
    assert points[1] is None and points[2] is not None and (points[2].x, points[2].y) == (3.0, 1.5)
    with pytest.raises(MissionError, match=r"step 2 \(inspect valve\): unknown target 'valve'"):
        resolve("robot1", [Step("dwell", seconds=1), Step("inspect", target="valve")], TARGETS, (3, 1.5), None, None)
    with pytest.raises(MissionError, match="outside the map"):
        resolve("robot1", [Step("goto", x=50.0, y=1.0)], TARGETS, (3.0, 1.5), FACILITY.grid, planner)
    with pytest.raises(MissionError, match=r"step 1 \(goto\): no path"):
        resolve("robot1", [Step("goto", x=6.0, y=6.0)], TARGETS, (3.0, 1.5), FACILITY.grid, planner)  # in a wall


class FakeFleet:
    """What the runner is given: goals go out, stops, captures and published records are recorded."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, ...]] = []
        self.published: list[MissionRecord] = []
        self.released: list[str] = []
        self.runner = MissionRunner(
            go=self.go, stop=self.stop, capture=self.capture, publish=self.publish, release=self.release
        )

    async def go(self, robot: str, x: float, y: float, yaw: float | None) -> None:
        self.calls.append(("go", robot, f"{x:g},{y:g}"))

    async def stop(self, robot: str) -> None:
        self.calls.append(("stop", robot))

    async def capture(self, record: MissionRecord, step: Step) -> None:
        self.calls.append(("capture", record.robot, step.target or ""))

    def publish(self, record: MissionRecord) -> None:
        self.published.append(record)

    def release(self, record: MissionRecord) -> None:
        self.released.append(record.id)

    def arrive(self, robot: str, outcome: str = "reached", message: str = "") -> None:
        self.runner.on_nav(NavEvent(robot, False, None, outcome, message))  # type: ignore[arg-type]

    async def settle(self) -> None:
        for _ in range(20):
            await asyncio.sleep(0)


def mission(steps: tuple[Step, ...]) -> MissionRecord:
    return MissionRecord("m1.robot1", "test", "robot1", steps, "pending", 0, "", 0.0, 0.0)


async def test_the_runner_goes_captures_and_finishes() -> None:
    fleet = FakeFleet()
    steps = (Step("inspect", target="spill"), Step("dwell", seconds=0.01), Step("capture"))
    from relay.inspection.missions import Waypoint

    run = fleet.runner.start(mission(steps), [Waypoint(0, 2.0, 7.0, 2.3), None, None])
    await fleet.settle()
    assert fleet.calls == [("go", "robot1", "2,7")]
    fleet.arrive("robot1")
    await asyncio.sleep(0.05)
    assert fleet.calls[1:] == [("capture", "robot1", "spill"), ("capture", "robot1", "")]
    assert run.record.state == "done" and run.record.current == 3 and fleet.released == ["m1.robot1"]
    assert [r.current for r in fleet.published] == [0, 1, 2, 3, 3]


async def test_pause_resume_skip_abort_and_stops() -> None:
    from relay.inspection.missions import Waypoint

    fleet = FakeFleet()
    steps = (Step("goto", x=1.0, y=1.0), Step("goto", x=2.0, y=2.0), Step("goto", x=3.0, y=3.0))
    run = fleet.runner.start(mission(steps), [Waypoint(i, i + 1.0, i + 1.0, None) for i in range(3)])
    await fleet.settle()
    await fleet.runner.act(run, "pause", "c1")
    assert run.record.state == "paused" and ("stop", "robot1") in fleet.calls
    await fleet.runner.act(run, "resume", "c2")
    await fleet.settle()
    assert fleet.calls.count(("go", "robot1", "1,1")) == 2  # the interrupted step starts over
    await fleet.runner.act(run, "skip", "c2")
    await fleet.settle()
    assert run.record.current == 1 and ("go", "robot1", "2,2") in fleet.calls
    fleet.arrive("robot1", "failed", "no path: blocked")
    await fleet.settle()
    assert run.record.state == "paused" and "blocked" in run.record.reason  # a failed goal pauses, with why
    await fleet.runner.act(run, "resume", "c2")
    await fleet.settle()
    fleet.runner.robot_stopped("robot1", "emergency stop by c3", estop=True)
    await fleet.settle()
    record: MissionRecord = run.record  # the runner replaced it
    # Held, not aborted: the lead resumes it after the reset, from the step it was at, or aborts it.
    assert record.state == "paused" and record.reason.startswith("emergency stop by c3; held")
    assert fleet.released == [] and record.current == 1
    goes = fleet.calls.count(("go", "robot1", "2,2"))
    await fleet.runner.act(run, "resume", "c1")
    await fleet.settle()
    resumed: MissionRecord = run.record  # the runner replaced it
    assert resumed.state == "running" and fleet.calls.count(("go", "robot1", "2,2")) == goes + 1
    await fleet.runner.act(run, "abort", "c1")
    ended: MissionRecord = run.record
    assert ended.state == "aborted" and fleet.released == ["m1.robot1"]
    with pytest.raises(ValueError, match="has ended"):
        await fleet.runner.act(run, "resume", "c1")


async def test_a_goal_nav2_aborts_pauses_its_mission_at_once_naming_why() -> None:
    from relay.inspection.missions import Waypoint

    fleet = FakeFleet()
    steps = (Step("goto", x=1.0, y=1.0), Step("capture"))
    run = fleet.runner.start(mission(steps), [Waypoint(0, 1.0, 1.0, None), None])
    await fleet.settle()
    why = "Nav2 aborted the goal: no valid path [error 208 (ComputePathToPose: no valid path)]"
    fleet.runner.on_nav(NavEvent("robot1", False, (1.0, 1.0, None), "failed", why, 208))
    await fleet.settle()  # no timeout, no wait: the next turns of the loop
    assert run.record.state == "paused" and run.record.current == 0
    assert run.record.reason == f"step 1: failed: {why}"
    assert ("capture", "robot1", "") not in fleet.calls  # the step after it did not run
    await fleet.runner.act(run, "resume", "c1")
    await fleet.settle()
    assert fleet.calls.count(("go", "robot1", "1,1")) == 2  # resumed: the same goal again


def test_a_pixel_of_the_camera_image_becomes_a_map_point() -> None:
    from relay.config import load_config
    from relay.inspection.pixel import pixel_to_map

    camera = load_config(ROOT / "robots.yaml").robots[0].cameras[0]  # 180 degree equidistant, 480 x 480
    pose = (3.0, 1.5, math.pi / 2)  # robot1's spawn, facing north through the chemical storage's door
    x, y = pixel_to_map(camera, 480, 480, pose, 239.5, 239.5, FACILITY.grid)  # the optical axis: level
    assert abs(x - 3.0) < 0.01 and 9.5 < y < 10.0  # the room's far wall
    assert not FACILITY.grid.is_free(x, y)
    # 60 degrees below the axis (an equidistant lens: 240 px for 90 degrees): the floor 0.3 / tan(60) m ahead.
    x, y = pixel_to_map(camera, 480, 480, pose, 239.5, 239.5 + 160, FACILITY.grid)
    assert abs(x - 3.0) < 0.01 and abs(y - (1.5 + 0.3 / math.tan(math.radians(60)))) < 0.01
    with pytest.raises(ValueError, match="outside the field"):
        pixel_to_map(camera, 480, 480, pose, 2, 2, FACILITY.grid)  # a corner of the image: black, no ray
    with pytest.raises(ValueError, match="looks at nothing"):
        pixel_to_map(camera, 480, 480, pose, 239.5, 100, None)  # upwards, with no map to stop it
