"""The hand's path to the arm beside the teleop path to the base (issue #32): from an operator's frame leaving to the
command arriving where the robot is, over real DDS, in the same run.

tools/fake_fleet.py runs the demo fleet (robot3 with the TurtleBot3 manipulator's arm, tools/fake_arm.py); the relay
runs in a process of its own as users run it (``--backend ros``). One operator sends, 20 times a second in turn, an
arm twist (what the page sends for a held hand: `robot3/arm/twist`) and a teleop command (`robot3/cmd_vel`); each
value is unique, so the probes (bench/base_probe.py) on MoveIt Servo's ``delta_twist_cmds`` and on the base's
``cmd_vel`` (through the robot's watchdog, as the demo's robots take it) find the frame each command came from.
The arm twists go up and down in turn and the base only turns, so nothing leaves its workspace or the room.

What this does not hold: the page's own part, one frame (the hand's pose is read and the twist sent in the same XR
frame: 14 ms at a headset's 72 Hz), which the e2e tests drive but do not time.
"""

from __future__ import annotations

import asyncio
import os
import secrets
import tempfile
import time
from pathlib import Path

from websockets.asyncio.client import connect

from .bench_estop import Operator, relay, stop_relay
from .common import ROOT, Child, JsonDict, Report, Settings, new_ros_domain, ros_env, summary, target

NAME = "arm"
TITLE = "The hand's twist to MoveIt Servo beside teleop to the base (DDS)"
ROBOT = "robot3"
SERVO = f"/{ROBOT}/servo_node/delta_twist_cmds"
BASE = f"/{ROBOT}/cmd_vel"
PERIOD = 0.05
#: The arm's path should cost no more than the base's: the same gate, one publish (no watchdog hop).
TARGET_RATIO = 1.2
ARM_FILES = ROOT.parent / "shared" / "data" / "robot" / "turtlebot3_manipulation_description"


def arm_speed(k: int) -> float:
    """The k-th arm twist's vertical speed (m/s): unique, under the arm's 0.1 m/s limit, up and down in turn."""
    return (0.01 + k * 1e-5) * (1 if k % 2 == 0 else -1)


def turn_rate(k: int) -> float:
    """The k-th teleop command's turn rate (rad/s): unique, under the base's limit, left and right in turn."""
    return (0.05 + k * 1e-4) * (1 if k % 2 == 0 else -1)


def first_arrivals(lines: list[JsonDict], read: str) -> dict[float, float]:
    """Each value's first arrival time at a probe (``read``: which field carries the unique value)."""
    seen: dict[float, float] = {}
    for line in lines:
        if "t" not in line:
            continue
        value = line["linear"][2] if read == "arm" else line["angular"]
        seen.setdefault(round(value, 7), line["t"])
    return seen


async def measure(samples: int, report: Report) -> JsonDict:
    token = secrets.token_urlsafe(24)
    env = ros_env(new_ros_domain())
    children: list[Child] = []
    process = None
    with tempfile.TemporaryDirectory(prefix="xr-bench-arm-") as tmp:
        try:
            children.append(await Child.start("arm-fleet", ["tools/fake_fleet.py"], env))
            servo = await Child.start("arm-servo-probe", ["-m", "bench.base_probe", "--topic", SERVO, "--stamped"], env)
            base = await Child.start("arm-base-probe", ["-m", "bench.base_probe", "--topic", BASE], env)
            children += [servo, base]
            args = ["--backend", "ros", "--config", str(ROOT / "robots.yaml"), "--token", token, "--audit-log", ""]
            process, url = await relay([*args, "--database", str(Path(tmp) / "i.sqlite")], env)
            for probe in (servo, base):
                await probe.wait_for(lambda line: line.get("ready") is True, 60)
            op = Operator(await connect(url.replace("http", "ws") + f"/ws?token={token}", max_size=None))
            await op.until(lambda m: m["identifier"] == f"{ROBOT}/joints", 60)
            # Until DDS has matched both ways: a command that reaches each probe.
            deadline = time.monotonic() + 60
            while not (first_arrivals(servo.lines, "arm") and first_arrivals(base.lines, "base")):
                if time.monotonic() > deadline:
                    raise TimeoutError("the probes got no command within 60 s")
                await op.send({"identifier": f"{ROBOT}/arm/twist", "linear": [0, 0, 0.001], "angular": [0, 0, 0]})
                await op.send({"identifier": f"{ROBOT}/cmd_vel", "linear": 0.0, "angular": 0.001})
                await asyncio.sleep(PERIOD)
            sent_arm: dict[float, float] = {}
            sent_base: dict[float, float] = {}
            for k in range(samples):
                v, w = arm_speed(k), turn_rate(k)
                sent_arm[round(v, 7)] = time.monotonic()
                await op.send({"identifier": f"{ROBOT}/arm/twist", "linear": [0, 0, v], "angular": [0, 0, 0]})
                sent_base[round(w, 7)] = time.monotonic()
                await op.send({"identifier": f"{ROBOT}/cmd_vel", "linear": 0.0, "angular": w})
                await asyncio.sleep(PERIOD)
            await op.send({"identifier": f"{ROBOT}/cmd_vel", "linear": 0.0, "angular": 0.0})
            await asyncio.sleep(1.0)
            await op.close()
        finally:
            await stop_relay(process)
            for child in reversed(children):
                await child.stop()
    arrived_arm, arrived_base = first_arrivals(servo.lines, "arm"), first_arrivals(base.lines, "base")
    arm = [arrived_arm[v] - t for v, t in sent_arm.items() if v in arrived_arm]
    teleop = [arrived_base[w] - t for w, t in sent_base.items() if w in arrived_base]
    frames = {line.get("frame") for line in servo.lines if "frame" in line}
    out: JsonDict = {
        "arm_ms": summary(arm),
        "teleop_ms": summary(teleop),
        "arm_lost": samples - len(arm),
        "teleop_lost": samples - len(teleop),
        "servo_frames": sorted(f for f in frames if f is not None),
    }
    report.line(
        f"hand twist to MoveIt Servo: p50 {out['arm_ms']['p50']} ms, p99 {out['arm_ms']['p99']} ms "
        f"({out['arm_lost']} of {samples} not seen); teleop to the base: p50 {out['teleop_ms']['p50']} ms, "
        f"p99 {out['teleop_ms']['p99']} ms ({out['teleop_lost']} not seen); servo frames {out['servo_frames']}"
    )
    return out


async def run(settings: Settings, report: Report) -> JsonDict:
    samples = int(settings.pick(400, 60))
    parameters: JsonDict = {"robot": ROBOT, "samples": samples, "period_s": PERIOD, "cpus": os.cpu_count()}
    if not ARM_FILES.is_dir():
        why = f"needs {ARM_FILES} (robot3's arm)"
        report.line(f"not measured: {why}")
        return {"parameters": parameters, "targets": [target("hand to servo", "measured", "not measured", None, why)]}
    try:
        result = await measure(samples, report)
    except Exception as exc:  # no rclpy, a fleet that did not start: say so in the report
        report.line(f"FAILED {exc!r}")
        return {"parameters": parameters, "error": repr(exc), "targets": [target("hand to servo", "measured",
                "not measured", None, repr(exc))]}  # fmt: skip
    arm, teleop = result["arm_ms"], result["teleop_ms"]
    ratio = arm["p99"] / teleop["p99"] if arm["p99"] and teleop["p99"] else None
    targets = [
        target(
            "an operator's arm twist to MoveIt Servo's topic (p99), against teleop to the base in the same run",
            f"<= {TARGET_RATIO:g}x teleop's p99, none lost",
            f"p50 {arm['p50']} ms, p99 {arm['p99']} ms ({ratio:.2f}x)" if ratio else "not measured",
            ratio is not None and ratio <= TARGET_RATIO and result["arm_lost"] == 0,
            baseline=f"teleop p50 {teleop['p50']} ms, p99 {teleop['p99']} ms",
        )
    ]
    return {"parameters": parameters, **result, "targets": targets}
