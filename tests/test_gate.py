"""The watchdog as the robot's gate, against a Nav2-faithful navigator (tools/fake_fleet.py --nav2): over real DDS
(the fake fleet and `xr-relay watchdog` in processes of their own, the relay stood in for by tests/gate_dds.py)
and over real Zenoh on loopback (tools/fake_fleet.py --zenoh --nav2, its watchdog in-process). The base moves only
from what the watchdog publishes on cmd_vel; every check is on what reaches it there and on the robot's pose.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from relay.config import FleetConfig, load_config
from relay.sim import navigator as nav
from tests.conftest import ROOT

FLEET = textwrap.dedent(
    """\
    safety: {deadman_timeout: 0.5, offline_after: 2.0}
    robots:
      - name: alpha
        pose: odom
        limits: {linear: 0.6, angular: 1.8}
        initial_pose: {x: 3.0, y: 1.5, yaw: 0.0}
        scan: null
        cmd_vel: {watchdog: true}
      - name: beta
        pose: odom
        limits: {linear: 0.6, angular: 1.8}
        initial_pose: {x: 9.0, y: 1.5, yaw: 0.0}
        scan: null
        cmd_vel: {watchdog: true}
        navigation: {on_relay_lost: continue}
    """
)


def distance(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def moving(samples: list[tuple[float, float, float]]) -> list[tuple[float, float, float]]:
    return [s for s in samples if s[1] != 0.0 or s[2] != 0.0]


@pytest.fixture
def fleet_file(tmp_path: Path) -> Path:
    path = tmp_path / "fleet.yaml"
    path.write_text(FLEET)
    return path


class Processes:
    """The robots' side: processes started by a test, each logging to a file, all stopped at the end."""

    def __init__(self, tmp_path: Path) -> None:
        self.tmp_path = tmp_path
        self.started: list[tuple[subprocess.Popen[bytes], Path]] = []

    def start(self, name: str, *args: str) -> subprocess.Popen[bytes]:
        log = self.tmp_path / f"{name}.log"
        with log.open("wb") as out:
            process = subprocess.Popen(
                [sys.executable, *args], cwd=ROOT, stdout=out, stderr=subprocess.STDOUT, env=dict(os.environ)
            )
        self.started.append((process, log))
        return process

    def fleet(self, config: Path, *flags: str) -> subprocess.Popen[bytes]:
        return self.start("fleet", str(ROOT / "tools" / "fake_fleet.py"), "--config", str(config), *flags)

    def watchdog(self, config: Path) -> subprocess.Popen[bytes]:
        return self.start("watchdog", "-m", "relay", "watchdog", "--config", str(config))

    def logs(self) -> str:
        return "\n".join(f"--- {log.name}\n{log.read_text()[-3000:]}" for _, log in self.started)

    def stop(self) -> None:
        for process, _ in self.started:
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
        for process, _ in self.started:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@pytest.fixture
def robots_side(tmp_path: Path) -> Iterator[Processes]:
    processes = Processes(tmp_path)
    try:
        yield processes
    finally:
        processes.stop()


# -- over DDS ---------------------------------------------------------------------------------------------------


@pytest.fixture
def dds_relay(ros_domain: int, fleet_file: Path) -> Iterator[tuple[FleetConfig, object]]:
    pytest.importorskip("rclpy", reason="rclpy is not importable: `pip install '.[ros]'` installs the ROS 2 wheels")
    from tests.gate_dds import DdsRelay

    config = load_config(fleet_file)
    relay = DdsRelay(config)
    try:
        yield config, relay
    finally:
        relay.close()


@pytest.mark.ros
def test_an_estop_holds_a_navigating_robot_against_its_controller_and_outlives_the_relay(
    dds_relay: tuple[FleetConfig, object], fleet_file: Path, robots_side: Processes
) -> None:
    from tests.gate_dds import DdsRelay, wait_until

    config, relay = dds_relay
    assert isinstance(relay, DdsRelay)
    robots_side.fleet(fleet_file, "--nav2", "--misbehave-after-cancel", "--no-watchdog")
    robots_side.watchdog(fleet_file)
    wait_until(lambda: relay.gate_states["alpha"], 60, "the watchdog's gate_state")
    assert relay.gate_states["alpha"][0] == "hold", "before the relay's first word the gate is hold"
    relay.gate("alpha", "drive")
    wait_until(lambda: relay.gate_states["alpha"][-1] == "drive", 10, "gate_state drive")

    # A goal on goal_pose drives the base: cmd_vel_nav -> the watchdog -> cmd_vel.
    start = relay.pose("alpha")
    uuid = relay.goal("alpha", 8.0, 1.5)
    wait_until(lambda: distance(relay.pose("alpha"), start) > 0.3, 20, "alpha driving to its goal")
    assert relay.status("alpha", uuid) == nav.EXECUTING
    assert moving(relay.cmd_vel["alpha"]), "the base got its commands on cmd_vel"

    # Estop: the gate latches; the cancel is accepted, and the controller misbehaves: it keeps publishing.
    estop = time.monotonic()
    relay.gate("alpha", "estop")
    response = relay.cancel("alpha", uuid)
    assert response.return_code == nav.ERROR_NONE
    assert [bytes(g.goal_id.uuid) for g in response.goals_canceling] == [uuid]
    wait_until(lambda: relay.status("alpha", uuid) == nav.CANCELED, 5, "the goal CANCELED")
    time.sleep(3.5 - (time.monotonic() - estop))
    held = relay.since(relay.cmd_vel["alpha"], estop + 0.3)
    assert not moving(held), f"non-zero commands reached the base after the estop: {moving(held)[:5]}"
    assert len(held) >= 3.0 * 20 * 0.7, f"{len(held)} zeros in 3.2 s: the latch sends them at 20 Hz"
    rogue = moving(relay.since(relay.autonomy["alpha"], estop + 0.3))
    assert len(rogue) >= 20, "the controller kept publishing after the cancel (the gate held against it)"
    stopped = relay.pose_at("alpha", estop + 0.3)
    assert distance(relay.pose("alpha"), stopped) <= 0.05, "alpha moved after the estop"
    assert relay.late_gate_state("alpha") == "estop", "gate_state reports the latch to a late subscriber"

    # The relay dies while latched: the latch outlives it.
    relay.die()
    died = time.monotonic()
    time.sleep(2.0)
    after = relay.since(relay.cmd_vel["alpha"], died)
    assert not moving(after) and len(after) >= 2.0 * 20 * 0.7, f"after the relay's death: {len(after)} commands"
    assert distance(relay.pose("alpha"), stopped) <= 0.05

    # A new relay learns the latch from gate_state, and its drive lets autonomy drive again.
    second = DdsRelay(config, "second_relay")
    try:
        assert second.late_gate_state("alpha") == "estop"
        second.gate("alpha", "drive")
        wait_until(lambda: second.gate_states["alpha"][-1:] == ["drive"], 10, "gate_state drive")
        here = second.pose("alpha")
        uuid = second.goal("alpha", 6.0, 1.5)
        wait_until(lambda: distance(second.pose("alpha"), here) > 0.3, 20, "alpha driving again")
        wait_until(lambda: second.status("alpha", uuid) == nav.SUCCEEDED, 30, "the new goal SUCCEEDED")
    finally:
        second.close()


@pytest.mark.ros
def test_a_watchdog_started_after_the_estop_latches_and_hold_blocks_autonomy_but_not_teleop(
    dds_relay: tuple[FleetConfig, object], fleet_file: Path, robots_side: Processes
) -> None:
    from tests.gate_dds import DdsRelay, wait_until

    _, relay = dds_relay
    assert isinstance(relay, DdsRelay)
    relay.gate("alpha", "estop")  # before any watchdog runs: the topic's history keeps it
    robots_side.fleet(fleet_file, "--nav2", "--no-watchdog")
    relay.goal("alpha", 8.0, 1.5)  # the controller drives, and nothing forwards it yet
    wait_until(lambda: moving(relay.autonomy["alpha"]), 10, "the controller's cmd_vel_nav")
    start = relay.pose("alpha")
    robots_side.watchdog(fleet_file)
    wait_until(lambda: "estop" in relay.gate_states["alpha"], 60, "the late watchdog's latch in gate_state")
    latched = time.monotonic()
    time.sleep(2.0)
    assert not moving(relay.cmd_vel["alpha"]), "a watchdog started after the estop forwarded a motion"
    assert len(relay.since(relay.cmd_vel["alpha"], latched)) >= 2.0 * 20 * 0.7, "zeros at 20 Hz"
    assert moving(relay.since(relay.autonomy["alpha"], latched)), "the controller was publishing all along"
    assert distance(relay.pose("alpha"), start) <= 0.05
    assert relay.late_gate_state("alpha") == "estop"

    # hold: the latch's zeros stop, autonomy stays blocked, teleop passes.
    relay.gate("alpha", "hold")
    wait_until(lambda: relay.gate_states["alpha"][-1] == "hold", 10, "gate_state hold")
    held = time.monotonic()
    time.sleep(1.0)
    assert relay.since(relay.cmd_vel["alpha"], held + 0.2) == [], "hold: no zeros, and no autonomy either"
    teleop = time.monotonic()
    for _ in range(20):
        relay.teleop("alpha", 0.3)
        time.sleep(0.05)
    assert [s for s in relay.since(relay.cmd_vel["alpha"], teleop) if s[1] == 0.3], "teleop passes a hold"
    relay.teleop("alpha", 0.0)

    # drive: once teleop is quiet, autonomy drives (a new goal, the first may have given up meanwhile).
    relay.gate("alpha", "drive")
    here = relay.pose("alpha")
    relay.goal("alpha", 7.0, 1.5)
    wait_until(lambda: distance(relay.pose("alpha"), here) > 0.3, 20, "alpha driven by autonomy after drive")


@pytest.mark.ros
def test_when_the_relays_heartbeat_stops_autonomy_holds_or_continues_per_robot(
    dds_relay: tuple[FleetConfig, object], fleet_file: Path, robots_side: Processes
) -> None:
    from tests.gate_dds import DdsRelay, wait_until

    _, relay = dds_relay
    assert isinstance(relay, DdsRelay)
    robots_side.fleet(fleet_file, "--nav2", "--no-watchdog")
    robots_side.watchdog(fleet_file)
    for robot in ("alpha", "beta"):
        wait_until(lambda r=robot: relay.gate_states[r], 60, f"{robot}'s gate_state")  # type: ignore[misc]
        relay.gate(robot, "drive")
    starts = {robot: relay.pose(robot) for robot in ("alpha", "beta")}
    relay.goal("alpha", 7.0, 1.5)
    relay.goal("beta", 14.0, 1.5)
    for robot in ("alpha", "beta"):
        wait_until(lambda r=robot: distance(relay.pose(r), starts[r]) > 0.2, 20, f"{robot} driving")  # type: ignore[misc]
    relay.heartbeat_on = False
    lost = time.monotonic()
    time.sleep(2.5)
    settled = lost + 0.5 + 0.3  # the timeout, then the base's braking
    assert not moving(relay.since(relay.cmd_vel["alpha"], lost + 0.5 + 0.05)), "on_relay_lost hold: alpha is held"
    assert distance(relay.pose("alpha"), relay.pose_at("alpha", settled)) <= 0.05
    assert moving(relay.since(relay.cmd_vel["beta"], settled)), "on_relay_lost continue: beta's autonomy goes on"
    assert distance(relay.pose("beta"), relay.pose_at("beta", settled)) > 0.3
