"""The relay runs a study (issue #34) over real WebSockets on the simulated fleet, its clock moved by hand: a
participant joins, a task starts from its instruction (the robot placed), the relay sees the robot reach the task's
region, the task's time is the relay's clock, the questionnaires are answered and exported as rows, a restart of the
relay in a task restores the run, and bad commands are refused by name and change nothing."""

from __future__ import annotations

import csv
import io
import json
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import pytest
from aiohttp import web

from relay.cli.options import Options
from relay.config import FleetConfig
from relay.errors import ConfigError
from relay.net.keys import RELAY_KEY
from relay.net.server import create_app, open_runner
from relay.study import cli as study_cli
from tests.conftest import RunningRelay, start_relay
from tests.helpers.study_files import DRIVE_STUDY, GOAL_AT
from tests.wsclient import TestClient

TOKEN = "study-token-for-tests-0123456789"
WAIT = 30.0  # s: a loaded machine's margin for a robot's drive and a reply; never what a test measures

GOAL = {"identifier": "robot1/goal_pose", "x": GOAL_AT[0], "y": GOAL_AT[1]}
SUS = [4, 2, 5, 1, 4, 2, 5, 1, 4, 2]  # (3+3+4+4+3+3+4+4+3+3) * 2.5 = 85
TLX = [40, 10, 30, 20, 50, 10]  # mean 26.67


class HandClock:
    """The relay's clock (monotonic seconds), moved by the test."""

    def __init__(self) -> None:
        self.now = time.monotonic()

    def __call__(self) -> float:
        return self.now


async def open_relay(
    fleet_config: FleetConfig, tmp_path: Path, clock: HandClock, backend_factory: Any = None
) -> RunningRelay:
    study = tmp_path / "study.yaml"
    if not study.exists():
        study.write_text(DRIVE_STUDY)
    options = Options(
        token=TOKEN, allow_viewers=True, study=str(study), study_runs=str(tmp_path / "runs"),
        database=str(tmp_path / "inspection.sqlite"),
    )  # fmt: skip
    app = create_app(fleet_config, options, clock=clock, backend_factory=backend_factory)
    runner = await open_runner(app)
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    host, port = runner.addresses[0][:2]
    return RunningRelay(f"http://{host}:{port}", f"ws://{host}:{port}/ws", app[RELAY_KEY], runner)


@pytest.fixture
async def running(fleet_config: FleetConfig, tmp_path: Path) -> AsyncIterator[tuple[RunningRelay, HandClock]]:
    clock = HandClock()
    relay = await open_relay(fleet_config, tmp_path, clock)
    try:
        yield relay, clock
    finally:
        await relay.runner.cleanup()


async def operator(running: RunningRelay) -> TestClient:
    client = await TestClient.open(f"{running.ws_url}?token={TOKEN}")
    assert (await client.hello())["role"] == "operator"
    return client


async def ask(client: TestClient, message: dict[str, Any]) -> dict[str, Any]:
    return await client.request(message, WAIT)


async def study_at(client: TestClient, phase: str, start: int = 0) -> dict[str, Any]:
    """The first ``study`` message at ``phase`` from message ``start`` on."""
    return await client.wait_for(lambda m: m["identifier"] == "study" and m["phase"] == phase, WAIT, start)


def latest_study(client: TestClient) -> dict[str, Any]:
    return [m for _, m in client.messages if m["identifier"] == "study"][-1]


async def do_task(client: TestClient, clock: HandClock, seconds: float) -> dict[str, Any]:
    """Start the task, send robot1 into the region, let ``seconds`` of the relay's clock pass on the way; the study
    message that says the task ended."""
    mark = len(client.messages)
    assert (await ask(client, {"identifier": "study/start"}))["identifier"] == "ack"
    await study_at(client, "task", mark)
    await client.wait_pose_near("robot1", 3.0, 1.0, 0.05, WAIT)  # placed where the task starts
    assert (await ask(client, GOAL))["identifier"] == "ack"
    clock.now += seconds  # while the robot drives: the region is metres away
    return await study_at(client, "questions", mark)


async def test_a_participant_does_a_task_the_relay_times_it_and_the_answers_are_exported(
    running: tuple[RunningRelay, HandClock], tmp_path: Path
) -> None:
    relay, clock = running
    client = await operator(relay)
    waiting = await study_at(client, "waiting")
    assert waiting["study"] == "drive-study" and waiting["participants"] == ["P01", "P02"]
    assert waiting["participant"] is None and waiting["task"] is None

    assert (await ask(client, {"identifier": "study/join", "participant": "P01"}))["identifier"] == "ack"
    ready = await study_at(client, "ready")
    assert ready["participant"] == "P01" and ready["condition"] == "desktop"
    assert ready["settings"] == {"view": "desktop", "sound": "off"}
    assert ready["instruction"] == "Send robot1 into chemical storage." and ready["time_limit"] == 120.0
    assert (ready["done"], ready["total"]) == (0, 2)

    ended = await do_task(client, clock, 7.25)
    # The task's time is the relay's clock: the 7.25 s it moved, to within a tick's rounding.
    assert ended["questionnaire"] == "tlx" and abs(ended["elapsed"] - 7.25) < 0.1
    pose = client.pose("robot1")
    assert pose is not None and pose["y"] > 3.0  # in chemical storage, as the relay saw it

    assert (await ask(client, {"identifier": "study/answer", "questionnaire": "tlx", "answers": TLX}))[
        "identifier"
    ] == ("ack")
    assert latest_study(client)["questionnaire"] == "sus"
    mark = len(client.messages)
    assert (await ask(client, {"identifier": "study/answer", "questionnaire": "sus", "answers": SUS}))[
        "identifier"
    ] == "ack"
    headset = await study_at(client, "ready", mark)
    assert headset["condition"] == "headset" and headset["settings"] == {"view": "headset"} and headset["done"] == 1

    await relay.runner.cleanup()  # the last changes written as the relay stops
    out = tmp_path / "results"
    argv = ["export", str(tmp_path / "study.yaml"), "--runs", str(tmp_path / "runs"), "--out", str(out)]
    assert study_cli.main(argv) == 0
    rows = list(csv.DictReader(io.StringIO((out / "drive-study.csv").read_text())))
    values = {(r["condition"], r["task"], r["measure"]): float(r["value"]) for r in rows}
    assert {r["participant"] for r in rows} == {"P01"}
    assert abs(values[("desktop", "reach-storage", "time_s")] - 7.25) < 0.1
    assert values[("desktop", "reach-storage", "success")] == 1.0
    assert values[("desktop", "reach-storage", "commands")] == 1.0  # the goal; the study's own are not counted
    assert values[("desktop", "reach-storage", "refusals")] == 0.0
    assert values[("desktop", "reach-storage", "restarts")] == 0.0
    assert values[("desktop", "reach-storage", "tlx")] == pytest.approx(160 / 6)
    assert values[("desktop", "", "sus")] == 85.0
    assert ("desktop", "reach-storage", "tlx_s") in values and ("desktop", "", "sus_s") in values


async def test_a_relay_restarted_in_a_task_goes_on_from_its_instruction(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    clock = HandClock()
    first = await open_relay(fleet_config, tmp_path, clock)
    try:
        client = await operator(first)
        assert (await ask(client, {"identifier": "study/join", "participant": "P02"}))["identifier"] == "ack"
        assert (await ask(client, {"identifier": "study/start"}))["identifier"] == "ack"
        await study_at(client, "task")
    finally:
        await first.runner.cleanup()
    saved = json.loads((tmp_path / "runs/drive-study/P02.json").read_text())
    assert saved["phase"] == "task"

    second = await open_relay(fleet_config, tmp_path, clock)
    try:
        client = await operator(second)
        restored = await study_at(client, "ready")  # the task starts again from its instruction
        assert restored["participant"] == "P02" and restored["condition"] == "headset"
        # Answers come from the participant's client: the new connection joins again.
        answer = {"identifier": "study/answer", "questionnaire": "tlx", "answers": TLX}
        assert (await ask(client, answer))["code"] == "forbidden"
        assert (await ask(client, {"identifier": "study/join", "participant": "P02"}))["identifier"] == "ack"
        ended = await do_task(client, clock, 3.5)
        assert abs(ended["elapsed"] - 3.5) < 0.1
    finally:
        await second.runner.cleanup()
    saved = json.loads((tmp_path / "runs/drive-study/P02.json").read_text())
    measures = {r["measure"]: r["value"] for r in saved["rows"]}
    assert measures["restarts"] == 1.0 and measures["success"] == 1.0 and abs(measures["time_s"] - 3.5) < 0.1


async def test_bad_study_commands_are_refused_by_name_and_change_nothing(
    running: tuple[RunningRelay, HandClock], tmp_path: Path
) -> None:
    relay, clock = running
    client = await operator(relay)
    viewer = await TestClient.open(relay.ws_url)
    assert (await viewer.hello())["role"] == "viewer"
    await study_at(client, "waiting")

    async def refused(sender: TestClient, message: dict[str, Any], code: str, says: str) -> None:
        reply = await ask(sender, message)
        assert reply["identifier"] == "error" and reply["code"] == code and says in reply["message"], reply

    await refused(client, {"identifier": "study/start"}, "bad_request", "no participant has joined")
    await refused(
        client, {"identifier": "study/join", "participant": "P99"}, "bad_request", "'P99' is not a participant"
    )
    await refused(viewer, {"identifier": "study/join", "participant": "P01"}, "forbidden", "operator")
    await refused(client, {"identifier": "study/answer", "probe": "corridor"}, "bad_request", "no participant")
    await refused(client, {"identifier": "study/answer"}, "bad_request", "exactly one of questionnaire, probe")
    await refused(
        client, {"identifier": "study/answer", "questionnaire": "nasa"}, "bad_request", "field 'questionnaire'"
    )
    assert latest_study(client)["phase"] == "waiting"

    assert (await ask(client, {"identifier": "study/join", "participant": "P01"}))["identifier"] == "ack"
    ready = await study_at(client, "ready")
    answer = {"identifier": "study/answer", "questionnaire": "tlx", "answers": TLX}
    await refused(client, answer, "bad_request", "tlx is not asked now")
    await refused(viewer, {"identifier": "study/start"}, "forbidden", "operator")
    assert latest_study(client) == ready

    mark = len(client.messages)
    assert (await ask(client, {"identifier": "study/start"}))["identifier"] == "ack"
    await study_at(client, "task", mark)
    await refused(client, {"identifier": "study/join", "participant": "P02"}, "bad_request", "P01 is in a task")
    await refused(client, {"identifier": "study/start"}, "bad_request", "the run is at task")
    assert (await ask(client, GOAL))["identifier"] == "ack"
    clock.now += 2.0
    ended = await study_at(client, "questions", mark)
    assert ended["questionnaire"] == "tlx"
    await refused(client, {"identifier": "study/start"}, "bad_request", "the run is at questions")
    await refused(
        client, {"identifier": "study/answer", "questionnaire": "sus", "answers": SUS}, "bad_request", "tlx is"
    )
    await refused(client, {**answer, "answers": [50, 50, 50]}, "bad_request", "NASA-TLX has 6 scales, got 3 answers")
    await refused(
        client, {**answer, "answers": [50, 50, 50, 50, 50, 101]}, "bad_request", "frustration: expected 0-100"
    )
    await refused(viewer, answer, "forbidden", "answers come from P01's client")
    assert latest_study(client)["questionnaire"] == "tlx"
    await relay.runner.cleanup()  # the last changes written as the relay stops
    saved = json.loads((tmp_path / "runs/drive-study/P01.json").read_text())
    assert [r["measure"] for r in saved["rows"]].count("tlx") == 0


async def test_a_relay_without_a_study_refuses_study_commands(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config)
    try:
        client = await TestClient.open(running.ws_url)
        await client.hello()
        reply = await ask(client, {"identifier": "study/join", "participant": "P01"})
        assert reply["code"] == "unsupported" and "--study FILE" in reply["message"]
        assert not [m for _, m in client.messages if m["identifier"] == "study"]
    finally:
        await running.runner.cleanup()


async def test_a_study_naming_a_robot_not_in_the_fleet_stops_the_start(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    (tmp_path / "study.yaml").write_text(DRIVE_STUDY.replace("robot: robot1", "robot: robot9"))
    with pytest.raises(ConfigError, match=r"tasks\[0\]\.success\.robot_in_region\.robot: \"robot9\" is not a robot"):
        await open_relay(fleet_config, tmp_path, HandClock())


#: One task whose success is a goal reached, with a probe a second in, and no questionnaires.
GOAL_STUDY = """\
study: goal-study
participants: [P01]
conditions: [{name: desktop, client: {view: desktop}}]
questionnaires: {after_task: [], after_condition: []}
tasks:
  - name: reach-goal
    instruction: Send robot1 a metre north.
    time_limit: 60
    start: {robots: {robot1: {x: 3.0, y: 1.0, yaw: 1.5708}}}
    success: {goal_reached: {robot: robot1}}
    probes: [{at: 1, question: room, robot: robot1}]
"""


async def test_a_probe_an_estop_a_refusal_a_goal_reached_and_view_switches_are_counted_in_the_task(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    (tmp_path / "study.yaml").write_text(GOAL_STUDY)
    clock = HandClock()
    running = await open_relay(fleet_config, tmp_path, clock)
    try:
        client = await operator(running)
        assert (await ask(client, {"identifier": "study/join", "participant": "P01"}))["identifier"] == "ack"
        mark = len(client.messages)
        assert (await ask(client, {"identifier": "study/start"}))["identifier"] == "ack"
        await study_at(client, "task", mark)
        await client.wait_pose_near("robot1", 3.0, 1.0, 0.05, WAIT)
        clock.now += 1.5  # past the probe's second: the task freezes and asks
        probe = (await study_at(client, "probe", mark))["probe"]
        assert probe["question"] == "room" and probe["robot"] == "robot1" and "corridor" in probe["choices"]
        assert (await ask(client, {"identifier": "study/answer", "probe": "nowhere"}))["code"] == "bad_request"
        assert (await ask(client, {"identifier": "study/answer", "probe": "corridor"}))["identifier"] == "ack"
        assert latest_study(client)["phase"] == "task"
        # What the page looks through, with its viewpoint: where it starts is no switch, the same view again neither.
        head = {"position": [3.0, 1.0, 1.6], "look": [1.0, 0.0, 0.0]}
        for view in ("orbit", "top", "top", "pov"):
            await client.send({"identifier": "viewer", "head": head, "view": view})
        mark_error = len(client.messages)
        await client.send({"identifier": "viewer", "head": head, "view": "sideways"})
        error = await client.wait_for(lambda m: m["identifier"] == "error", WAIT, mark_error)
        assert error["code"] == "bad_request" and "view must be one of orbit, top" in error["message"], error

        assert (await ask(client, {"identifier": "estop"}))["identifier"] == "ack"
        goal = {"identifier": "robot1/goal_pose", "x": 3.0, "y": 2.0}
        assert (await ask(client, goal))["code"] == "estopped"
        assert (await ask(client, {"identifier": "estop", "action": "reset"}))["identifier"] == "ack"
        assert (await ask(client, goal))["identifier"] == "ack"
        done = await study_at(client, "done", mark)  # the goal reached is the task's success, and the last task
        assert done["done"] == 1 and done["task"] is None
    finally:
        await running.runner.cleanup()
    saved = json.loads((tmp_path / "runs/goal-study/P01.json").read_text())
    measures = {r["measure"]: r["value"] for r in saved["rows"]}
    assert measures["success"] == 1.0 and measures["time_s"] == pytest.approx(1.5)
    assert measures["probe_correct"] == 1.0 and measures["probe_room_s"] == 0.0
    assert (measures["commands"], measures["refusals"], measures["estops"]) == (4.0, 1.0, 1.0)
    assert measures["view_switches"] == 2.0  # orbit -> top -> pov


async def test_a_task_that_places_robots_is_refused_where_the_backend_cannot_place_them(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    from tests.helpers.station import FakeBackend

    running = await open_relay(
        fleet_config, tmp_path, HandClock(), backend_factory=lambda c, sink, o: FakeBackend(c, sink)
    )
    try:
        client = await operator(running)
        assert (await ask(client, {"identifier": "study/join", "participant": "P01"}))["identifier"] == "ack"
        ready = await study_at(client, "ready")
        backend = running.relay.backend
        assert isinstance(backend, FakeBackend)
        calls = list(backend.calls)
        reply = await ask(client, {"identifier": "study/start"})
        assert reply["code"] == "unsupported", reply
        assert "robot1: the fake backend cannot place robots (only the sim backend can)" in reply["message"]
        assert latest_study(client) == ready  # the task did not start
        assert backend.calls == calls  # and no robot was stopped, nor anything sent to one
    finally:
        await running.runner.cleanup()


def test_the_command_line_refuses_a_bad_study_file_naming_its_line_and_field(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from relay.cli.main import main
    from tests.conftest import ROOT

    bad = tmp_path / "study.yaml"
    bad.write_text(DRIVE_STUDY.replace("time_limit: 120", "time_limit: soon"))
    argv = ["--config", str(ROOT / "robots.yaml"), "--study", str(bad), "--no-accounts", "--audit-log", ""]
    assert main(argv) == 2
    assert f'--study: {bad}:11: tasks[0].time_limit: expected a positive number, got "soon"' in caplog.text
