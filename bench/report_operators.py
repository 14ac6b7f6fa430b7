"""The sections of the operator's own paths: the hand's twist to the arm (bench/bench_arm.py) and what recording a
session costs the relay (bench/bench_recording.py)."""

from __future__ import annotations

from .common import JsonDict, fmt
from .report_page import Page, pct, section, table

ARM_DOC = """An operator's arm twist (what the page sends for a held hand, `robot3/arm/twist`) to MoveIt Servo's
`delta_twist_cmds` where the robot is, beside a teleop command to the base's `cmd_vel` (through the robot's
watchdog) in the same run, 20 of each a second in turn (bench/bench_arm.py). Over DDS: `tools/fake_fleet.py` runs the
demo fleet, robot3 with the TurtleBot3 manipulator's arm (tools/fake_arm.py), the relay a process of its own
(`--backend ros`), the probes (bench/base_probe.py) time each command where it arrives. Not included: the page's own
part, one frame (the hand is read and its twist sent in the same XR frame: 14 ms at a headset's 72 Hz).
"""

RECORDING_DOC = """What `--record-session` (issue #34: the session as MCAP, for replay) costs the relay: the pose
fan-out's target cell (100 robots at 30 Hz to 20 clients, bench/bench_pose_fanout.py) with and without it, in turns
(off, on, off, on) so that a machine growing busier weighs on both alike (bench/bench_recording.py).
"""


def arm_section(page: Page, r: JsonDict) -> None:
    if not section(page, r, ARM_DOC):
        return
    rows = []
    for path, key, lost in (("hand twist to MoveIt Servo", "arm_ms", "arm_lost"),
                            ("teleop to the base", "teleop_ms", "teleop_lost")):  # fmt: skip
        x = r.get(key)
        if x is None:
            continue
        rows.append([path, fmt(x["p50"], 1), fmt(x["p99"], 1), fmt(x["max"], 1), f"{x['n']} ({r[lost]} lost)"])
    page.add(table(["path", "p50 ms", "p99 ms", "max ms", "commands"], rows))


def recording_section(page: Page, r: JsonDict) -> None:
    if not section(page, r, RECORDING_DOC):
        return
    rows = []
    for c in r.get("cells", []):
        if "error" in c:
            rows.append(["on" if c.get("recording") else "off", "failed", "", "", ""])
            continue
        size = f"{c['file_bytes'] / 1e6:.1f}" if "file_bytes" in c else ""
        latency = c["latency_ms"]
        rows.append(
            [
                "on" if c["recording"] else "off",
                pct(c["cpu"]["server"]),
                f"{fmt(latency['p50'], 2)} / {fmt(latency['p99'], 2)}",
                pct(c["delivered_fraction"]),
                size,
            ]
        )
    page.add(table(["recording", "relay CPU", "pose p50 / p99 ms", "delivered", "file MB"], rows))
