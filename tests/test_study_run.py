"""A participant's run through a study (issue #34) with a clock moved by hand: task times with probes excluded,
success and the time limit, near-collisions, teleop and goal time, questionnaires in their order, the run saved
and restored across a restart, and the results as tidy CSV and their summary."""

from __future__ import annotations

import csv
import io
import json

import pytest

from relay.study.model import Probe
from relay.study.results import summarise, tidy_csv
from relay.study.run import RunState, StudyError, StudyRun
from relay.study.scores import AnswerError
from relay.study.study_file import parse_study
from relay.study.summary_html import summary_html
from tests.helpers.study_files import RADII, VALVE_STUDY, tick

STUDY_ = parse_study(VALVE_STUDY)


def measures(run: StudyRun, task: str, condition: str) -> dict[str, float]:
    return {r.measure: r.value for r in run.rows() if r.task == task and r.condition == condition}


def test_a_task_times_its_success_without_its_probe_and_counts_what_happened() -> None:
    run = StudyRun(STUDY_, RunState("P02"))  # the Latin square's second row: desktop first
    assert run.condition == "desktop" and run.settings == {"view": "desktop", "sound": "off"}
    assert run.begin(100.0).name == "reach-spill"
    run.command(refused=False)
    run.command(refused=True)
    assert tick(run, 110.0, robot1="teleop") is None  # 10 s of teleop
    # robot2 comes within 0.2 m of robot1, edge to edge (centres 0.5 m apart, radii 0.2): one near-collision.
    close = {"robot1": (2.0, 3.0), "robot2": (2.5, 3.0)}
    assert tick(run, 120.0, close, robot1="navigating") is None
    assert tick(run, 125.0, close, robot1="navigating") is None, "still close: not counted again"
    probe = tick(run, 131.0, robot1="navigating")
    assert isinstance(probe, Probe) and probe.question == "room", "30 s in: the probe"
    assert tick(run, 140.0) is None, "frozen: the task's clock stands"
    assert run.answer_probe("corridor", 136.0) is True
    with pytest.raises(StudyError, match="no probe is asked now"):
        run.answer_probe("corridor", 137.0)
    run.estop()
    run.view_switch()
    assert tick(run, 150.0, {"robot1": (10.0, 2.0), "robot2": (20.0, 3.0)}) == "success"
    m = measures(run, "reach-spill", "desktop")
    # 100 -> 131 is 31 s; the probe 131 -> 136 does not count; 136 -> 150 is 14 s.
    assert m["time_s"] == pytest.approx(45.0) and m["success"] == 1.0
    assert (m["commands"], m["refusals"], m["estops"], m["view_switches"]) == (2, 1, 1, 1)
    assert m["near_collisions"] == 1 and m["teleop_s"] == 10.0 and m["goal_s"] == pytest.approx(21.0)
    assert m["probe_correct"] == 1.0 and m["probe_room_s"] == 5.0 and m["restarts"] == 0
    # The TLX comes after the task; the SUS is not asked yet.
    assert run.state.phase == "questions" and run.state.pending == ["tlx"]
    with pytest.raises(StudyError, match=r"sus is not asked now \(tlx is\)"):
        run.answer("sus", [3] * 10, 151.0)
    with pytest.raises(AnswerError, match="NASA-TLX effort: expected 0-100"):
        run.answer("tlx", [50, 50, 50, 50, 150, 50], 151.0)
    assert run.answer("tlx", [60, 0, 30, 20, 50, 10], 162.0) == pytest.approx(170 / 6)
    assert measures(run, "reach-spill", "desktop")["tlx_s"] == 12.0
    assert str(run.state.phase) == "ready" and run.task.name == "mark-spill"


def test_the_limit_ends_a_task_and_a_collision_spoils_a_clean_goal_then_the_sus_and_the_next_condition() -> None:
    run = StudyRun(STUDY_, RunState("P01", task=1))
    run.begin(0.0)
    assert tick(run, 60.0) is None
    run.finding("valve")  # another target than the task's
    assert tick(run, 121.0) == "limit"
    assert measures(run, "mark-spill", "headset")["time_s"] == 120.0, "the limit, not the late tick"
    assert measures(run, "mark-spill", "headset")["success"] == 0.0
    run.answer("tlx", [10] * 6, 130.0)
    run.begin(200.0)
    assert tick(run, 201.0, {"robot1": (2.0, 3.0), "robot2": (2.3, 3.0)}) is None  # a near-collision
    run.goal_reached("robot2")
    assert tick(run, 230.0, robot2="navigating") is None, "reached, but not without a collision"
    assert tick(run, 291.0) == "limit"
    assert measures(run, "park", "headset")["success"] == 0.0
    run.answer("tlx", [20] * 6, 300.0)
    assert run.state.pending == ["sus"] and run.state.asking == "condition"
    assert run.answer("sus", [4, 2, 5, 3, 3, 2, 4, 1, 4, 2], 320.0) == 75.0
    sus = [r for r in run.rows() if r.measure == "sus"]
    assert [(r.condition, r.task) for r in sus] == [("headset", "")], "the SUS is the condition's, not a task's"
    assert run.state.phase == "ready" and run.condition == "desktop" and run.task.name == "reach-spill"


def test_a_run_saved_mid_task_restarts_that_task_and_keeps_what_was_measured() -> None:
    run = StudyRun(STUDY_, RunState("P03"))
    run.begin(0.0)
    tick(run, 50.0, {"robot1": (10.0, 2.0), "robot2": (20.0, 3.0)})
    run.answer("tlx", [30] * 6, 60.0)
    run.begin(70.0)
    tick(run, 80.0)
    saved = json.loads(json.dumps(run.saved()))  # as the store writes it
    again = StudyRun.restored(STUDY_, saved)
    assert again.state.phase == "ready" and again.task.name == "mark-spill" and again.state.restarts == 1
    assert measures(again, "reach-spill", "headset")["time_s"] == 50.0, "the finished task kept"
    again.begin(1000.0)
    again.finding("spill")
    assert tick(again, 1007.5) == "success"
    assert measures(again, "mark-spill", "headset")["time_s"] == 7.5
    assert measures(again, "mark-spill", "headset")["restarts"] == 1
    with pytest.raises(StudyError, match="'P9' is not a participant of valve-and-spill"):
        StudyRun(STUDY_, RunState("P9"))


def test_results_are_tidy_csv_and_a_summary_per_condition() -> None:
    rows = []
    for participant, seconds in (("P01", 40.0), ("P02", 50.0), ("P03", 90.0)):
        run = StudyRun(STUDY_, RunState(participant))
        run.begin(0.0)
        tick(run, seconds, {"robot1": (10.0, 2.0), "robot2": (20.0, 3.0)})
        rows += run.rows()
    table = list(csv.DictReader(io.StringIO(tidy_csv(rows))))
    assert list(table[0]) == ["study", "participant", "condition", "task", "measure", "value"]
    times = [(r["participant"], r["condition"], float(r["value"])) for r in table if r["measure"] == "time_s"]
    assert times == [("P01", "headset", 40.0), ("P02", "desktop", 50.0), ("P03", "headset", 90.0)]
    summary = {(s.condition, s.measure): s for s in summarise(rows, ["headset", "desktop"])}
    headset = summary[("headset", "time_s")]
    assert (headset.n, headset.mean, headset.median) == (2, 65.0, 65.0)
    assert headset.sd == pytest.approx(35.355339, abs=1e-5)  # sqrt(((40-65)^2 + (90-65)^2) / 1)
    assert summary[("desktop", "time_s")].sd is None, "one value: no spread"
    page = summary_html("valve-and-spill", list(summary.values()), 3)
    assert "<h2>Time to success or the limit (s)</h2>" in page and page.count("<svg") == len({m for _, m in summary})
    assert "<td>headset</td><td>2</td><td>65</td><td>35.4</td><td>65</td>" in page


def test_a_wall_within_a_hand_of_a_robots_edge_is_a_near_collision() -> None:
    from relay.study.rules import contacts

    def wall_at_x0(x: float, y: float, limit: float) -> float:
        return min(limit, max(0.0, x))

    assert contacts({"robot1": (0.35, 5.0)}, RADII, wall_at_x0) == {("robot1", "wall")}, "edge 0.15 m from it"
    assert contacts({"robot1": (0.45, 5.0)}, RADII, wall_at_x0) == frozenset(), "edge 0.25 m from it"
    two = {"robot1": (3.0, 5.0), "robot2": (3.55, 5.0)}
    assert contacts(two, RADII, wall_at_x0) == {("robot1", "robot2")}, "edges 0.15 m apart: one, not one each"
