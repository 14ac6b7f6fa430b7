"""An arm's commands through the relay's rules, without sockets and without sleeping: robot1 of the demo fleet given a
two-joint arm (tests/helpers/arm.py's planar URDF, so that no shared data is needed), a fake backend that records
what reaches the arm, a clock moved by hand. The same gates as a base's: one lease covers both, an estop latches the
arm, the deadman stops it when the hand's twists stop, a motion past a joint limit is refused and nothing moves."""

from __future__ import annotations

import asyncio
import dataclasses
import threading
from pathlib import Path
from typing import Any

import numpy as np
import orjson
import pytest

from relay.arm.kinematics import jacobian
from relay.arm.named import NAMED_SPEED_SCALE
from relay.backends.base import Backend
from relay.cli.options import Options
from relay.config import Arm, ArmTopics, FleetConfig, Limits, Workspace
from relay.control import arm_control
from relay.fleet.events import EventSink, JointStateEvent
from relay.station.core import Relay
from tests.helpers.arm import PLANAR_URDF, planar
from tests.helpers.station import Clock, FakeBackend, Station

#: Upper arm level, forearm turned 0.5 rad down: the tip at about (0.38, 0, 0.10), clear of every bound.
START = (0.0, 0.5)
UP = {"linear": [0.0, 0.0, 0.05], "angular": [0.0, 0.0, 0.0]}


#: The planar arm's named poses, as MoveIt's SRDF names them.
SRDF = """<robot name="planar"><group name="arm"><chain base_link="base_link" tip_link="tip"/></group>
<group_state name="home" group="arm"><joint name="shoulder" value="0"/><joint name="elbow" value="1.0"/></group_state>
</robot>"""


def with_arm(config: FleetConfig, urdf: Path) -> FleetConfig:
    topics = ArmTopics("/robot1/joint_states", "/robot1/servo", "/robot1/trajectory", "/robot1/gripper")
    srdf = urdf.with_suffix(".srdf")
    srdf.write_text(SRDF)
    bounds = Limits(0.1, 0.5), Workspace((-0.5, -0.5, -0.5), (0.6, 0.5, 0.6))
    arm = Arm(urdf, "base_link", "tip", None, topics, *bounds, srdf=srdf)
    robots = tuple(dataclasses.replace(r, arm=arm) if r.name == "robot1" else r for r in config.robots)
    return dataclasses.replace(config, robots=robots)


@pytest.fixture
async def station(fleet_config: FleetConfig, tmp_path: Path) -> Any:
    urdf = tmp_path / "planar.urdf"
    urdf.write_text(PLANAR_URDF)
    clock = Clock()
    holder: dict[str, FakeBackend] = {}

    def factory(config: FleetConfig, sink: EventSink, options: Options) -> Backend:
        holder["backend"] = FakeBackend(config, sink)
        return holder["backend"]

    options = Options(audit_log=str(tmp_path / "audit.jsonl"), max_message_rate=100.0, lease_timeout=30.0)
    relay = Relay(with_arm(fleet_config, urdf), options, backend_factory=factory, clock=clock)
    await relay.arms.start()
    await relay.backend.start()
    joints(relay, START)
    yield Station(relay, holder["backend"], clock)
    await relay.stop()


def joints(relay: Relay, positions: tuple[float, float]) -> None:
    relay.on_event(JointStateEvent("robot1", 1.0, ("shoulder", "elbow"), positions))


def twist(request_id: int | None = None, **fields: Any) -> dict[str, Any]:
    message = {"identifier": "robot1/arm/twist", **UP, **fields}
    return message if request_id is None else {**message, "id": request_id}


async def test_a_twist_is_clamped_and_reaches_the_arm(station: Station) -> None:
    client, seen = station.connect()
    await station.send(client, twist(1, linear=[0.0, 0.0, 3.0]))
    assert seen.replies(1) == [{"identifier": "ack", "id": 1}]
    assert station.backend.arm_moves("robot1") == [("arm_twist", "robot1", (0.0, 0.0, 0.1), (0.0, 0.0, 0.0))]
    assert station.relay.control.leases.holder("robot1") == client.client_id


async def test_the_robots_lease_covers_its_arm(station: Station) -> None:
    driver, _ = station.connect()
    other, seen = station.connect()
    viewer, watched = station.connect(role="viewer")
    await station.send(driver, {"identifier": "robot1/cmd_vel", "linear": 0.1, "angular": 0.0})  # takes the lease
    for client in (other, viewer):
        await station.send(client, twist(2))
        await station.send(client, {"identifier": "robot1/arm/gripper", "id": 3, "position": 0.01})
        await station.send(client, {"identifier": "robot1/arm/pose", "id": 4, "name": "home"})
    for request_id in (2, 3, 4):
        assert seen.replies(request_id)[0]["code"] == "leased"
        assert driver.client_id in seen.replies(request_id)[0]["message"]
        assert watched.replies(request_id)[0]["code"] == "forbidden"
    assert station.backend.arm_moves("robot1") == []
    await station.send(driver, twist(5))
    assert station.backend.arm_moves("robot1") == [("arm_twist", "robot1", (0.0, 0.0, 0.05), (0.0, 0.0, 0.0))]


async def test_the_deadman_stops_the_arm_when_the_hands_twists_stop(station: Station) -> None:
    client, _ = station.connect()
    timeout = station.relay.config.safety.deadman_timeout
    for _ in range(5):  # a hand that keeps sending keeps the arm moving
        await station.send(client, twist())
        await station.tick(timeout / 2)
    assert ("arm_stop", "robot1") not in station.backend.arm_moves("robot1")
    await station.tick(timeout / 2 - 0.05)
    assert station.backend.arm_moves("robot1")[-1][0] == "arm_twist"
    await station.tick(0.1)
    assert station.backend.arm_moves("robot1")[-1] == ("arm_stop", "robot1")
    # Once: a silent arm is not stopped again and again.
    await station.tick(1.0)
    assert station.backend.arm_moves("robot1").count(("arm_stop", "robot1")) == 1


async def test_a_disconnect_stops_the_arm_at_once(station: Station) -> None:
    client, _ = station.connect()
    await station.send(client, twist())
    await station.relay.disconnect(client)
    assert station.backend.arm_moves("robot1")[1] == ("arm_stop", "robot1")


async def test_an_estop_stops_the_arm_and_latches_every_arm_command(station: Station) -> None:
    client, seen = station.connect()
    await station.send(client, twist(1))
    await station.send(client, {"identifier": "estop", "id": 2, "robot": "robot1"})
    assert station.backend.arm_moves("robot1")[-1] == ("arm_stop", "robot1")  # through the robot's stop
    before = list(station.backend.arm_moves("robot1"))
    await station.send(client, twist(3))
    await station.send(client, {"identifier": "robot1/arm/pose", "id": 4, "name": "home"})
    await station.send(client, {"identifier": "robot1/arm/gripper", "id": 5, "state": "close"})
    for request_id in (3, 4, 5):
        [error] = seen.replies(request_id)
        assert error["code"] == "estopped" and "reset it first" in error["message"], error
    assert station.backend.arm_moves("robot1") == before
    # A zero twist is a stop: it always passes.
    await station.send(client, twist(6, linear=[0.0, 0.0, 0.0]))
    assert seen.replies(6) == [{"identifier": "ack", "id": 6}]
    await station.send(client, {"identifier": "estop", "id": 7, "robot": "robot1", "action": "reset"})
    await station.send(client, twist(8))
    assert seen.replies(8) == [{"identifier": "ack", "id": 8}]
    assert station.backend.arm_moves("robot1")[-1][0] == "arm_twist"


async def test_a_twist_past_a_joint_limit_is_refused_with_the_reason_and_nothing_moves(station: Station) -> None:
    # The elbow 0.005 rad short of its margin (limit -2.5, margin 0.1): the hand asks for the tip motion that folds
    # it further.
    near = (0.0, -2.395)
    joints(station.relay, near)
    folding = -jacobian(planar(), near)[:3, 1]
    client, seen = station.connect()
    await station.send(client, twist(1, linear=(0.1 * folding / np.linalg.norm(folding)).tolist()))
    [error] = seen.replies(1)
    assert error["code"] == "arm_refused", error
    assert "elbow would come within 0.1 of its lower limit -2.500" in error["message"]
    assert [c for c in station.backend.arm_moves("robot1") if c[0] != "arm_stop"] == []
    # Away from the limit it moves.
    await station.send(client, twist(2, linear=(-0.1 * folding / np.linalg.norm(folding)).tolist()))
    assert seen.replies(2) == [{"identifier": "ack", "id": 2}]


async def test_a_twist_without_a_joint_state_or_for_a_robot_without_an_arm_is_refused(
    fleet_config: FleetConfig, station: Station
) -> None:
    client, seen = station.connect()
    await station.send(client, {**twist(1), "identifier": "robot2/arm/twist"})
    [error] = seen.replies(1)
    assert error["code"] == "no_arm" and "robot2 has no arm" in error["message"]
    station.relay.arms.positions.clear()
    await station.send(client, twist(2))
    assert seen.replies(2)[0]["code"] == "arm_refused" and "no joint state" in seen.replies(2)[0]["message"]
    assert station.backend.arm_moves("robot1") == [] and station.backend.arm_moves("robot2") == []
    assert station.relay.control.leases.holder("robot2") is None  # refused before it took anything


async def test_a_twist_in_the_tips_frame_is_turned_into_the_base_links(station: Station) -> None:
    # At START the tip frame is turned 0.5 rad about y: its x axis points forward and down.
    client, _ = station.connect()
    await station.send(client, twist(linear=[0.05, 0.0, 0.0], frame="tip"))
    [(_, _, linear, _)] = station.backend.arm_moves("robot1")
    assert linear == pytest.approx((0.05 * np.cos(0.5), 0.0, -0.05 * np.sin(0.5)))


async def test_arm_commands_are_audited_like_every_command(station: Station, tmp_path: Path) -> None:
    client, seen = station.connect()
    await station.send(client, {"identifier": "robot1/arm/pose", "id": "p1", "name": "home"})
    await station.send(client, {"identifier": "robot1/arm/gripper", "id": "g1", "state": "open"})
    records = [orjson.loads(line) for line in (tmp_path / "audit.jsonl").read_text().splitlines()]
    assert [r.get("identifier") for r in records if r.get("id") in ("p1", "g1")] == [
        "robot1/arm/pose",
        "robot1/arm/gripper",
    ]
    assert seen.replies("g1")[0]["code"] == "arm_refused", seen.replies("g1")  # this arm has no gripper
    assert [call[:3] for call in station.backend.arm_moves("robot1")] == [("arm_pose", "robot1", "home")]


async def test_a_named_pose_reaches_the_arm_as_its_joints_timed_by_the_slowest(station: Station) -> None:
    """The relay resolves the SRDF's pose into what an arm controller takes: every joint's position, and the time the
    farthest joint needs at a named pose's share of its limit (the planar URDF's 2 rad/s: 0.2 rad/s)."""
    client, seen = station.connect()
    await station.send(client, {"identifier": "robot1/arm/pose", "id": 1, "name": "home"})
    assert seen.replies(1) == [{"identifier": "ack", "id": 1}]
    (call,) = station.backend.arm_moves("robot1")
    goal = call[3]
    assert goal.names == ("shoulder", "elbow") and goal.positions == (0.0, 1.0)
    assert goal.seconds == pytest.approx(abs(1.0 - START[1]) / (2.0 * NAMED_SPEED_SCALE))
    await station.send(client, {"identifier": "robot1/arm/pose", "id": 2, "name": "stow"})
    (refusal,) = seen.replies(2)
    assert refusal["code"] == "arm_refused" and '"stow"' in refusal["message"] and "home" in refusal["message"]
    assert len(station.backend.arm_moves("robot1")) == 1  # nothing more reached the arm


class HeldChecks:
    """The twists' look-ahead check (relay.control.arm_control._checked, the real one) held on its worker thread
    until the test lets it finish: what arrives meanwhile is seen as arriving while a twist is checked."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.started = threading.Event()
        self.release = threading.Event()
        real = arm_control._checked

        def held(*args: Any) -> Any:
            self.started.set()
            self.release.wait(10.0)
            return real(*args)

        monkeypatch.setattr(arm_control, "_checked", held)

    async def wait_started(self) -> None:
        assert await asyncio.to_thread(self.started.wait, 10.0), "the twist's check never started"


@pytest.mark.parametrize("stop", ["zero twist", "estop"])
async def test_a_stop_while_a_twist_is_checked_is_handled_at_once_and_voids_the_twist(
    station: Station, monkeypatch: pytest.MonkeyPatch, stop: str
) -> None:
    held = HeldChecks(monkeypatch)
    client, seen = station.connect()
    await station.send(client, twist(1), apart=False)  # handed to the worker; the client's frames go on
    await held.wait_started()
    if stop == "estop":
        await station.send(client, {"identifier": "estop", "id": 2, "robot": "robot1"}, apart=False)
    else:
        await station.send(client, twist(2, linear=[0.0, 0.0, 0.0]), apart=False)
    # The stop did not wait behind the check: it is answered and reached the arm while the check still runs.
    assert seen.replies(2) == [{"identifier": "ack", "id": 2}]
    assert station.backend.arm_moves("robot1")[-1] == ("arm_stop", "robot1")
    held.release.set()
    await station.settle()
    [error] = seen.replies(1)
    assert error["code"] == ("estopped" if stop == "estop" else "superseded"), error
    assert "nothing reached the arm" in error["message"] or "reset it first" in error["message"], error
    assert [c[0] for c in station.backend.arm_moves("robot1")] == ["arm_stop"]  # the twist never reached it
