"""The command rules without sockets and without sleeping: a fake backend, a recording transport, a clock we move.

Each test drives ``Relay`` exactly as the server does (``connect``, ``handle_text``, ``disconnect``) and the
ticker as the loop does (``supervisor.tick(now)``), with ``now`` chosen by the test. What a client is told is
read from its transport once the hub's writers have drained their lanes; what reaches a robot is read from the
backend's call log. The behaviour tests over real sockets (test_relay_ws.py, test_access.py) stay.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import orjson
import pytest

from relay.backends.base import Backend
from relay.cli.options import Options
from relay.config import FleetConfig
from relay.fleet.events import EventSink, FrameEvent, PoseEvent
from relay.session.budget import OPERATOR_RESERVE, TOTAL
from relay.session.freshness import CREEP
from relay.session.ratelimit import TokenBucket
from relay.station.audit import QUIET_RATE
from relay.station.core import Relay
from tests.helpers.station import Clock, FakeBackend, Station


@pytest.fixture
async def station(fleet_config: FleetConfig, tmp_path: Path) -> Any:
    clock = Clock()
    holder: dict[str, FakeBackend] = {}

    def factory(config: FleetConfig, sink: EventSink, options: Options) -> Backend:
        holder["backend"] = FakeBackend(config, sink)
        return holder["backend"]

    options = Options(audit_log=str(tmp_path / "audit.jsonl"), max_message_rate=10.0, lease_timeout=30.0)
    relay = Relay(fleet_config, options, backend_factory=factory, clock=clock)
    await relay.backend.start()
    yield Station(relay, holder["backend"], clock)
    await relay.stop()


def audit_records(tmp_path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (tmp_path / "audit.jsonl").read_text().splitlines()]


# -- teleop, clamps and the deadman ---------------------------------------------------------------


async def test_cmd_vel_is_clamped_to_the_robots_limits_and_acked(station: Station) -> None:
    client, seen = station.connect()
    await station.send(client, {"identifier": "robot1/cmd_vel", "id": 1, "linear": 5.0, "angular": -9.0})
    assert seen.replies(1) == [{"identifier": "ack", "id": 1}]
    # robots.yaml limits robot1 to 0.6 m/s and 1.8 rad/s; teleop cancels navigation first.
    assert ("cancel", "robot1") in station.backend.calls
    assert station.backend.moves("robot1") == [("velocity", "robot1", 0.6, -1.8)]
    assert station.relay.fleet.status("robot1", station.clock.now)["mode"] == "teleop"


async def test_deadman_stops_a_robot_whose_operator_falls_silent(station: Station) -> None:
    client, _ = station.connect()
    await station.send(client, {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0})
    timeout = station.relay.config.safety.deadman_timeout
    await station.tick(timeout - 0.05)
    assert station.backend.moves("robot1")[-1] == ("velocity", "robot1", 0.3, 0.0)
    await station.tick(0.1)
    assert station.backend.moves("robot1")[-1] == ("velocity", "robot1", 0.0, 0.0)
    assert station.relay.fleet.status("robot1", station.clock.now)["mode"] == "idle"


async def test_commands_that_keep_coming_keep_the_deadman_quiet(station: Station) -> None:
    client, _ = station.connect()
    for _ in range(10):
        await station.send(client, {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0})
        await station.tick(0.1)
    assert ("velocity", "robot1", 0.0, 0.0) not in station.backend.moves("robot1")


async def test_a_motion_command_that_waited_past_the_deadman_is_dropped(station: Station) -> None:
    # The relay was frozen (SIGSTOP, a starved loop) while the frames sat read but unhandled: replaying them
    # would move a robot the deadman has stopped.
    client, seen = station.connect()
    timeout = station.relay.config.safety.deadman_timeout
    late = station.clock.now - timeout - 0.1
    await station.send(client, {"identifier": "robot1/cmd_vel", "id": 1, "linear": 0.3, "angular": 0.0}, received=late)
    await station.send(client, {"identifier": "robot1/goal_pose", "id": 2, "x": 3.0, "y": 6.0}, received=late)
    for request_id in (1, 2):
        [error] = seen.replies(request_id)
        assert error["code"] == "stale" and "nothing reached the robot" in error["message"], error
    assert station.backend.moves("robot1") == []
    # A frame read within the timeout still drives, stamped with when it reached the relay.
    await station.send(client, {"identifier": "robot1/cmd_vel", "id": 3, "linear": 0.3, "angular": 0.0},
                       received=station.clock.now - timeout + 0.1)  # fmt: skip
    assert seen.replies(3) == [{"identifier": "ack", "id": 3}]
    assert station.backend.moves("robot1") == [("velocity", "robot1", 0.3, 0.0)]
    wall = station.relay.commands.wall_clock()
    assert station.backend.stamps[-1] == pytest.approx(wall - timeout + 0.1, abs=0.05)


async def test_stamped_commands_buffered_while_the_relay_was_frozen_are_dropped(station: Station) -> None:
    # 20 Hz teleop stamped with the client's clock (t, ms), whose offset from the relay's is arbitrary.
    client, seen = station.connect()
    client.allowance = TokenBucket.full(100.0, station.clock.now)  # the 10/s of this station would drop the burst
    offset = 123_456.0

    async def drive(sent: float, received: float, request_id: int) -> None:
        message = {"identifier": "robot1/cmd_vel", "id": request_id, "linear": 0.3, "angular": 0.0,
                   "t": (sent + offset) * 1000}  # fmt: skip
        await station.send(client, message, received=received)

    for i in range(20):  # one second of normal driving: each frame reaches the relay 5-15 ms after it was sent
        station.clock.now += 0.05
        await drive(station.clock.now - 0.005 - 0.01 * (i % 2), station.clock.now, i)
    assert all(seen.replies(i)[0]["identifier"] == "ack" for i in range(20))
    # The relay is frozen for 3 s. The client sent 60 frames meanwhile; they all arrive when it resumes.
    frozen_at = station.clock.now
    station.clock.now += 3.0
    for i in range(60):
        await drive(frozen_at + 0.05 * (i + 1), station.clock.now, 100 + i)
    codes = [seen.replies(100 + i)[0].get("code", "ack") for i in range(60)]
    # Those sent more than the deadman's timeout (0.5 s) before the relay resumed are dropped, the last ~0.5 s go;
    # the estimate may read ages young by its creep over the silence (relay.session.freshness: 0.02 s/s x 3 s).
    timeout = station.relay.config.safety.deadman_timeout
    ages = [3.0 - 0.05 * (i + 1) for i in range(60)]
    assert all(code == "stale" for code, age in zip(codes, ages, strict=True) if age > timeout + CREEP * 3.0), codes
    assert all(code == "ack" for code, age in zip(codes, ages, strict=True) if age < timeout), codes
    assert len(station.backend.moves("robot1")) == 20 + codes.count("ack")


async def test_a_goal_during_teleop_stops_teleop_before_the_goal(station: Station) -> None:
    client, seen = station.connect()
    await station.send(client, {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0})
    await station.send(client, {"identifier": "robot1/goal_pose", "id": "g", "x": 3.0, "y": 6.0})
    assert seen.replies("g") == [{"identifier": "ack", "id": "g"}]
    assert station.backend.moves("robot1")[-2:] == [
        ("velocity", "robot1", 0.0, 0.0),
        ("goal", "robot1", 3.0, 6.0, None),
    ]
    # The deadman no longer watches robot1: a goal is not teleop.
    await station.tick(5.0)
    assert station.backend.moves("robot1")[-1] == ("goal", "robot1", 3.0, 6.0, None)


async def test_disconnect_stops_the_robot_and_ends_the_lease(station: Station) -> None:
    driver, _ = station.connect()
    _, watcher = station.connect("viewer")
    await station.send(driver, {"identifier": "robot2/cmd_vel", "linear": 0.4, "angular": 0.2})
    await station.relay.disconnect(driver)
    await station.settle()
    assert station.backend.moves("robot2")[-1] == ("velocity", "robot2", 0.0, 0.0)
    assert station.backend.calls[-2] == ("cancel", "robot2")
    lease = watcher.of("robot2/lease")[-1]
    assert lease == {
        "identifier": "robot2/lease",
        "holder": None,
        "previous": driver.client_id,
        "reason": "disconnected",
    }


# -- leases and take-over -------------------------------------------------------------------------


async def test_a_second_operator_is_refused_until_they_take_over(station: Station) -> None:
    first, first_seen = station.connect()
    second, second_seen = station.connect()
    await station.send(first, {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0})
    assert first_seen.of("robot1/lease")[-1]["holder"] == first.client_id

    await station.send(second, {"identifier": "robot1/goal_pose", "id": "g", "x": 3.0, "y": 6.0})
    (error,) = second_seen.replies("g")
    assert error["code"] == "leased" and first.client_id in error["message"]
    assert ("goal", "robot1", 3.0, 6.0, None) not in station.backend.calls

    before = len(station.backend.calls)
    await station.send(second, {"identifier": "robot1/lease", "id": "t", "force": True})
    assert second_seen.replies("t") == [{"identifier": "ack", "id": "t"}]
    # The robot stops (no velocity, no goal) before it changes hands, and both operators are told.
    assert station.backend.calls[before:] == [("cancel", "robot1"), ("velocity", "robot1", 0.0, 0.0)]
    change = {"identifier": "robot1/lease", "holder": second.client_id, "previous": first.client_id}
    assert first_seen.of("robot1/lease")[-1] == {**change, "reason": "taken_over"}
    assert station.relay.fleet.status("robot1", station.clock.now)["controller"] == second.client_id

    await station.send(first, {"identifier": "robot1/cmd_vel", "id": 5, "linear": 0.3, "angular": 0.0})
    assert first_seen.replies(5)[0]["code"] == "leased"
    assert station.backend.moves("robot1")[-1] == ("velocity", "robot1", 0.0, 0.0)


async def test_only_the_holder_can_release_and_release_stops_the_robot(station: Station) -> None:
    holder, _ = station.connect()
    other, other_seen = station.connect()
    await station.send(holder, {"identifier": "robot3/goal_pose", "id": "g", "x": 15.0, "y": 6.0})
    await station.send(other, {"identifier": "robot3/lease", "id": "r", "action": "release"})
    assert other_seen.replies("r")[0]["code"] == "leased"
    await station.send(holder, {"identifier": "robot3/lease", "id": "r2", "action": "release"})
    assert station.backend.calls[-2:] == [("cancel", "robot3"), ("velocity", "robot3", 0.0, 0.0)]
    assert other_seen.of("robot3/lease")[-1]["reason"] == "released"


async def test_an_idle_lease_expires_and_the_robot_stops(station: Station) -> None:
    holder, seen = station.connect()
    await station.send(holder, {"identifier": "robot2/lease", "id": "l"})
    await station.tick(station.relay.options.lease_timeout - 1.0)
    assert seen.of("robot2/lease")[-1]["reason"] == "acquired"
    await station.tick(2.0)
    assert seen.of("robot2/lease")[-1] == {
        "identifier": "robot2/lease",
        "holder": None,
        "previous": holder.client_id,
        "reason": "expired",
    }
    assert station.backend.calls[-2:] == [("cancel", "robot2"), ("velocity", "robot2", 0.0, 0.0)]


async def test_viewers_cannot_command_and_nothing_reaches_a_robot(station: Station) -> None:
    viewer, seen = station.connect("viewer")
    before = list(station.backend.calls)
    commands: list[dict[str, Any]] = [
        {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0},
        {"identifier": "robot1/goal_pose", "x": 3.0, "y": 6.0},
        {"identifier": "robot1/lease", "force": True},
        {"identifier": "estop"},
        {"identifier": "robot1/cancel"},
    ]
    for i, message in enumerate(commands):
        await station.send(viewer, {**message, "id": i})
        assert seen.replies(i)[0]["code"] == "forbidden"
    assert station.backend.calls == before


# -- estop ----------------------------------------------------------------------------------------


async def test_estop_reaches_every_robot_it_can_and_names_the_one_it_could_not(station: Station) -> None:
    operator, seen = station.connect()
    _, other = station.connect()
    await station.send(operator, {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0})
    station.backend.broken.add("robot2")
    await station.send(operator, {"identifier": "estop", "id": "stop"})

    # Exactly one reply, an error naming robot2; the connection stays open and keeps working.
    (reply,) = seen.replies("stop")
    assert reply["identifier"] == "error" and "robot2" in reply["message"] and "motor driver" in reply["message"]
    assert seen.closed is None
    assert station.backend.moves("robot1")[-1] == ("velocity", "robot1", 0.0, 0.0)
    assert station.backend.moves("robot3")[-1] == ("velocity", "robot3", 0.0, 0.0)
    # Every client learns which robots were stopped, ahead of their state lanes.
    stopped = {"identifier": "estop", "robots": ["robot1", "robot3"], "by": operator.client_id, "latched": True}
    assert other.of("estop") == [stopped]
    assert station.relay.fleet.status("robot1", station.clock.now)["mode"] == "idle"

    await station.send(operator, {"identifier": "ping", "t": 1.5})
    assert seen.of("pong")[-1]["t"] == 1.5


async def test_estop_of_one_robot_acks_and_leaves_the_others_alone(station: Station) -> None:
    operator, seen = station.connect()
    await station.send(operator, {"identifier": "robot2/goal_pose", "id": "g", "x": 9.0, "y": 6.0})
    await station.send(operator, {"identifier": "estop", "id": "e", "robot": "robot1"})
    assert seen.replies("e") == [{"identifier": "ack", "id": "e"}]
    assert seen.of("estop")[-1]["robots"] == ["robot1"]
    assert station.backend.moves("robot2") == [("goal", "robot2", 9.0, 6.0, None)]


async def test_estop_latches_until_an_operator_resets_it(station: Station) -> None:
    holder, seen = station.connect()
    other, other_seen = station.connect()
    viewer, viewer_seen = station.connect("viewer")
    await station.send(holder, {"identifier": "robot1/cmd_vel", "linear": 0.3, "angular": 0.0})
    await station.send(other, {"identifier": "estop", "id": "e"})
    assert station.backend.moves("robot1")[-1] == ("velocity", "robot1", 0.0, 0.0)
    before = list(station.backend.calls)

    # The holder's 20 Hz stream goes on: nothing of it reaches the robot, each command is told why.
    for i in range(5):
        await station.send(holder, {"identifier": "robot1/cmd_vel", "id": i, "linear": 0.3, "angular": 0.0})
        (error,) = seen.replies(i)
        assert error["code"] == "estopped" and other.client_id in error["message"]
        station.clock.now += 0.05
    await station.send(holder, {"identifier": "robot2/goal_pose", "id": "g", "x": 9.0, "y": 6.0})
    assert seen.replies("g")[0]["code"] == "estopped"
    assert station.backend.calls == before
    status = seen.of("robot1/status")[-1]
    assert status["estopped"] is True and status["mode"] == "idle"
    # A client that connects now sees the latch in hello.
    _, late = station.connect()
    await station.settle()
    assert late.of("hello")[0]["state"]["robot2"]["status"]["estopped"] is True

    # A viewer cannot lift it; an operator can, for one robot or all.
    await station.send(viewer, {"identifier": "estop", "id": "v", "action": "reset"})
    assert viewer_seen.replies("v")[0]["code"] == "forbidden"
    await station.send(holder, {"identifier": "estop", "id": "r1", "robot": "robot1", "action": "reset"})
    assert other_seen.of("estop")[-1] == {
        "identifier": "estop",
        "robots": ["robot1"],
        "by": holder.client_id,
        "latched": False,
    }
    assert station.backend.calls == before, "a reset moves nothing: the robots stay stopped"
    await station.send(holder, {"identifier": "robot1/cmd_vel", "id": "go", "linear": 0.3, "angular": 0.0})
    assert seen.replies("go") == [{"identifier": "ack", "id": "go"}]
    await station.send(holder, {"identifier": "robot2/cmd_vel", "id": "no", "linear": 0.3, "angular": 0.0})
    assert seen.replies("no")[0]["code"] == "estopped", "robot2 is still latched"
    await station.send(holder, {"identifier": "estop", "id": "r", "action": "reset"})
    assert seen.of("robot2/status")[-1]["estopped"] is False


@pytest.mark.parametrize("overtaker", ["estop", "take_over", "cancel", "teleop", "newer_goal"])
async def test_a_goal_still_being_planned_is_dropped_when_something_overtakes_it(
    station: Station, overtaker: str
) -> None:
    holder, seen = station.connect()
    other, _ = station.connect()
    station.backend.planning = asyncio.Event()
    goal = {"identifier": "robot1/goal_pose", "id": "old", "x": 3.0, "y": 6.0}
    # The goal is planned beside the client's later frames: handling it returns at once.
    await station.send(holder, goal, apart=False)
    (planning,) = holder.tasks
    if overtaker == "estop":
        # The same client's estop does not wait behind its own slow goal: acknowledged while it is planned.
        await station.send(holder, {"identifier": "estop", "id": "e", "robot": "robot1"}, apart=False)
        assert seen.replies("e") == [{"identifier": "ack", "id": "e"}] and not planning.done()
    elif overtaker == "take_over":
        await station.send(other, {"identifier": "robot1/lease", "id": "t", "force": True}, apart=False)
    elif overtaker == "cancel":
        await station.send(holder, {"identifier": "robot1/cancel", "id": "c"}, apart=False)
    elif overtaker == "teleop":
        await station.send(holder, {"identifier": "robot1/cmd_vel", "linear": 0.2, "angular": 0.0}, apart=False)
    else:
        await station.send(holder, {**goal, "id": "new", "x": 9.0}, apart=False)
    station.backend.planning.set()
    await station.settle()
    (reply,) = seen.replies("old")
    assert reply["identifier"] == "error" and reply["code"] == "superseded"
    assert ("goal", "robot1", 3.0, 6.0, None) not in station.backend.calls, "the robot never follows the old plan"
    if overtaker == "newer_goal":
        assert seen.replies("new") == [{"identifier": "ack", "id": "new"}]
        assert station.backend.moves("robot1")[-1] == ("goal", "robot1", 9.0, 6.0, None)


# -- rate limits ----------------------------------------------------------------------------------


async def test_rate_limit_drops_commands_but_never_an_estop(station: Station) -> None:
    operator, seen = station.connect()
    rate = station.relay.options.max_message_rate
    burst = int(2 * rate)
    for i in range(burst + 3):
        await station.send(operator, {"identifier": "robot1/cmd_vel", "id": i, "linear": 0.1, "angular": 0.0})
    codes = [seen.replies(i)[0]["identifier"] for i in range(burst)]
    assert codes == ["ack"] * burst
    assert [seen.replies(i)[0]["code"] for i in range(burst, burst + 3)] == ["rate_limited"] * 3
    assert len(station.backend.moves("robot1")) == burst

    await station.send(operator, {"identifier": "estop", "id": "e"})
    assert seen.replies("e") == [{"identifier": "ack", "id": "e"}]

    # Time refills the bucket: one second later, `rate` more pass (the estop latched robot1: another robot).
    station.clock.now += 1.0
    await station.send(operator, {"identifier": "robot2/cmd_vel", "id": "later", "linear": 0.1, "angular": 0.0})
    assert seen.replies("later")[0]["identifier"] == "error" and seen.replies("later")[0]["code"] == "estopped"
    await station.send(operator, {"identifier": "estop", "id": "r", "action": "reset"})
    await station.send(operator, {"identifier": "robot2/cmd_vel", "id": "later2", "linear": 0.1, "angular": 0.0})
    assert seen.replies("later2")[0]["identifier"] == "ack"


async def test_a_flood_of_bad_frames_is_rate_limited_and_cannot_wipe_the_audit_log(
    station: Station, tmp_path: Path
) -> None:
    attacker, seen = station.connect("viewer")
    operator, _ = station.connect()
    long_name = "r" * 1000
    for i in range(300):
        frame = b"{not json" if i % 2 else orjson.dumps({"identifier": f"{long_name}/cancel", "id": i})
        await station.relay.handle_text(attacker, frame)
        station.clock.now += 0.001  # 300 frames in 0.3 s
    await station.settle()
    records = audit_records(tmp_path)
    rate = station.relay.options.max_message_rate
    # Refusals are recorded within the client's audit budget (relay.station.audit): its burst and what it earns back in
    # 0.3 s, not 300 lines; the rest are counted.
    assert len(records) <= 2 * QUIET_RATE + 0.3 * QUIET_RATE + 1, len(records)
    assert max(len(json.dumps(r)) for r in records) < 600, "no record echoes the 1000-character name"
    assert all(len(m.get("message") or "") < 300 for m in seen.texts if m["identifier"] == "error")
    # The operator's own commands are recorded as ever; a second later the attacker's next drop is recorded
    # with the count of those that were not.
    await station.send(operator, {"identifier": "robot1/cancel", "id": "mine"})
    station.clock.now += 1.0
    for _ in range(int(2 * rate)):  # more than the bucket earned back in that second
        await station.relay.handle_text(attacker, b"{not json")
    records = audit_records(tmp_path)
    assert ("robot1/cancel", "mine", "accepted") in [(r["identifier"], r["id"], r["outcome"]) for r in records]
    later = records[[r["id"] for r in records].index("mine") + 1 :]
    assert "not written since the last" in later[0]["message"], later[0]


# -- replies, snapshots, audit --------------------------------------------------------------------


async def test_snapshot_runs_apart_and_answers_with_a_frame_then_an_ack(station: Station) -> None:
    operator, seen = station.connect()
    await station.send(operator, {"identifier": "robot1/snapshot", "id": "s"})
    assert seen.replies("s")[0]["code"] == "no_camera"
    station.backend.frame = FrameEvent(
        robot="robot1", camera="front", stamp=12.5, width=480, height=480, jpeg=b"\xff\xd8jpeg\xff\xd9"
    )
    await station.send(operator, {"identifier": "robot1/snapshot", "id": "s2"})
    ((header, payload),) = seen.frames
    assert header["identifier"] == "robot1/camera/front" and header["request_id"] == "s2"
    assert header["width"] == 480 and header["lens"]["model"] == "equidistant" and payload.startswith(b"\xff\xd8")
    assert seen.replies("s2") == [{"identifier": "ack", "id": "s2"}]


async def test_snapshots_are_budgeted_per_client_and_viewers_cannot_starve_operators(station: Station) -> None:
    station.backend.frame = FrameEvent(
        robot="robot1", camera="front", stamp=12.5, width=480, height=480, jpeg=b"\xff\xd8jpeg\xff\xd9"
    )
    station.backend.planning = None
    gate = asyncio.Event()
    slow = station.backend.snapshot

    async def held(robot: str, camera: str) -> FrameEvent | None:
        await gate.wait()  # a render that takes a while
        return await slow(robot, camera)

    station.backend.snapshot = held  # type: ignore[method-assign]
    viewers = [station.connect("viewer") for _ in range(4)]
    for i, (viewer, _) in enumerate(viewers):
        for j in range(3):  # each viewer floods
            await station.send(viewer, {"identifier": "robot1/snapshot", "id": f"v{i}-{j}"}, apart=False)
    refusals = [m for _, seen in viewers for m in seen.texts if m.get("code") == "busy"]
    started = sum(1 for i, (_, seen) in enumerate(viewers) for j in range(3) if not seen.replies(f"v{i}-{j}"))
    assert started == TOTAL - OPERATOR_RESERVE and len(refusals) == 12 - started
    assert any("kept for operators" in m["message"] for m in refusals)
    assert any("already in progress" in m["message"] for m in refusals)
    # The operator's snapshot is taken although the viewers asked first, and more often.
    operator, seen = station.connect()
    await station.send(operator, {"identifier": "robot1/snapshot", "id": "op"}, apart=False)
    gate.set()
    await station.settle()
    assert seen.replies("op") == [{"identifier": "ack", "id": "op"}] and len(seen.frames) == 1
    served = sum(len(s.frames) for _, s in viewers)
    assert served == started


async def test_every_frame_is_audited_with_its_outcome(station: Station, tmp_path: Path) -> None:
    operator, _ = station.connect()
    viewer, _ = station.connect("viewer")
    await station.send(operator, {"identifier": "robot2/goal_pose", "id": "a", "x": 9.0, "y": 6.0, "yaw": 1.0})
    await station.send(operator, {"identifier": "robot9/cancel", "id": "b"})
    await station.send(viewer, {"identifier": "robot1/cancel", "id": "c"})
    await station.relay.handle_text(operator, b"{not json")
    await station.send(operator, {"identifier": "ping", "t": 1.0})
    records = audit_records(tmp_path)
    assert [(r["identifier"], r["id"], r["outcome"], r["code"]) for r in records] == [
        ("robot2/goal_pose", "a", "accepted", None),
        ("robot9/cancel", "b", "refused", "unknown_robot"),
        ("robot1/cancel", "c", "refused", "forbidden"),
        (None, None, "refused", "bad_request"),
    ]
    assert records[0]["values"] == {"x": 9.0, "y": 6.0, "yaw": 1.0}
    assert records[2]["client"] == viewer.client_id and records[2]["role"] == "viewer"


async def test_status_goes_online_with_the_first_pose_and_offline_when_poses_stop(station: Station) -> None:
    _, seen = station.connect()
    station.relay.on_event(PoseEvent("robot1", station.clock.now, "map", 3.0, 1.5, 0.0, 0.0, 0.0, 0.0, 1.0))
    await station.settle()
    assert seen.of("robot1/status")[-1]["online"] is True
    await station.tick(station.relay.config.safety.offline_after + 0.1)
    assert seen.of("robot1/status")[-1]["online"] is False
