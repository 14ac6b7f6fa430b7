"""The studies the study tests run (issue #34), and a study run's clock tick as the relay gives it: pure data, no
relay (the relay that runs one for the browser tests: tests/helpers/study.py)."""

from __future__ import annotations

from relay.study.model import Probe
from relay.study.run import StudyRun

#: Four participants, two conditions, a valve to close and a spill to reach: every kind of task and questionnaire.
VALVE_STUDY = """\
study: valve-and-spill
participants: [P01, P02, P03, P04]
conditions:
  - {name: headset, client: {view: headset}}
  - {name: desktop, client: {view: desktop, sound: off}}
questionnaires: {after_task: [tlx], after_condition: [sus]}
tasks:
  - name: reach-spill
    instruction: Send robot1 to the spill in chemical storage.
    time_limit: 180
    start: {reset_estop: true, robots: {robot1: {x: 2.0, y: 3.0, yaw: 0}}}
    success: {robot_in_region: {robot: robot1, region: [[9, 1], [12, 1], [12, 4], [9, 4]]}}
    probes: [{at: 30, question: room, robot: robot2}]
  - name: mark-spill
    instruction: Mark the spill as a finding.
    time_limit: 120
    success: {finding_at_target: {target: spill}}
  - name: park
    instruction: Park robot2 at the dock without touching anything.
    time_limit: 90
    success: {goal_reached: {robot: robot2, without_collision: true}}
"""

#: Robot1 starts in the corridor; the task's region is in chemical storage, a few metres and a door away.
DRIVE_STUDY = """\
study: drive-study
participants: [P01, P02]
conditions:
  - {name: desktop, client: {view: desktop, sound: off}}
  - {name: headset, client: {view: headset}}
order: {P01: [desktop, headset], P02: [headset, desktop]}
questionnaires: {after_task: [tlx], after_condition: [sus]}
tasks:
  - name: reach-storage
    instruction: Send robot1 into chemical storage.
    time_limit: 120
    start: {reset_estop: true, robots: {robot1: {x: 3.0, y: 1.0, yaw: 1.5708}}}
    success: {robot_in_region: {robot: robot1, region: [[2, 4], [4, 4], [4, 5.5], [2, 5.5]]}}
"""
GOAL_AT = (3.0, 4.7)  # in the region

RADII = {"robot1": 0.2, "robot2": 0.2}
FAR = {"robot1": (2.0, 3.0), "robot2": (20.0, 3.0)}


def truth(probe: Probe) -> str:
    return {"room": "corridor"}[probe.question]


def tick(run: StudyRun, now: float, poses: dict[str, tuple[float, float]] | None = None, **modes: str) -> object:
    return run.tick(now, poses or FAR, modes, RADII, None, truth)
