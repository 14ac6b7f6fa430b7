"""`xr-relay study check|export` (issue #34): runs kept in their folder survive a restart mid-task, and the export
writes the tidy CSV and the HTML summary from them; a damaged run or study file is named, nothing written."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from relay.cli.main import main
from relay.study.store import RunStore
from relay.study.study_file import load_study
from tests.helpers.study_files import VALVE_STUDY, tick

INSIDE = {"robot1": (10.0, 2.0), "robot2": (20.0, 3.0)}


def test_runs_survive_a_restart_and_export_as_csv_and_html(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    study_file = tmp_path / "study.yaml"
    study_file.write_text(VALVE_STUDY)
    runs = tmp_path / "runs"
    store = RunStore(runs, load_study(study_file))
    first = store.load("P01")
    first.begin(0.0)
    tick(first, 42.5, INSIDE)
    first.answer("tlx", [40] * 6, 50.0)
    store.save(first)
    first.begin(60.0)
    store.save(first)  # the relay stops here, in the second task
    # A new relay: the same store, read again.
    again = RunStore(runs, load_study(study_file)).load("P01")
    assert again.state.phase == "ready" and again.task.name == "mark-spill" and again.state.restarts == 1
    again.begin(1000.0)
    again.finding("spill")
    tick(again, 1003.25)
    store.save(again)
    assert main(["study", "check", str(study_file)]) == 0
    assert "P02: desktop, headset" in capsys.readouterr().out
    out = tmp_path / "out"
    assert main(["study", "export", str(study_file), "--runs", str(runs), "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "valve-and-spill.csv").open()))
    times = {r["task"]: float(r["value"]) for r in rows if r["measure"] == "time_s"}
    assert times == {"reach-spill": 42.5, "mark-spill": 3.25}
    assert {r["participant"] for r in rows} == {"P01"} and {r["condition"] for r in rows} == {"headset"}
    restarts = {r["task"]: r["value"] for r in rows if r["measure"] == "restarts"}
    assert restarts == {"reach-spill": "0.0", "mark-spill": "1.0"}
    page = (out / "valve-and-spill.html").read_text()
    assert "<h1>valve-and-spill</h1>" in page and "<p>1 participant.</p>" in page


def test_a_damaged_run_or_study_is_named_and_nothing_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    study_file = tmp_path / "study.yaml"
    study_file.write_text(VALVE_STUDY)
    runs = tmp_path / "runs" / "valve-and-spill"
    runs.mkdir(parents=True)
    (runs / "P02.json").write_text('{"participant": "P02", "phase": ')
    out = tmp_path / "out"
    assert main(["study", "export", str(study_file), "--runs", str(tmp_path / "runs"), "--out", str(out)]) == 2
    assert "P02.json: not a readable run" in capsys.readouterr().err
    assert not out.exists()
    (runs / "P02.json").write_text('{"participant": "P02", "owner": "someone"}')
    assert main(["study", "export", str(study_file), "--runs", str(tmp_path / "runs"), "--out", str(out)]) == 2
    assert "P02.json: not a run of this relay" in capsys.readouterr().err
    study_file.write_text(VALVE_STUDY.replace("time_limit: 180", "time_limit: -1"))
    assert main(["study", "check", str(study_file)]) == 2
    assert "study.yaml:10: tasks[0].time_limit: expected a positive number, got -1" in capsys.readouterr().err
