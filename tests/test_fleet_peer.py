"""Control with another relay of the fleet behind a FleetPeer (relay/control/fleet_peer.py), without sockets: a fake
peer records what this relay tells the others and plays what they would tell it. tests/test_zenoh_fleet.py runs the same
over a real Zenoh router with two real relays.
"""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import hypothesis.strategies as st
import pytest
from hypothesis import given

from relay.backends.base import Backend
from relay.cli.options import Options
from relay.config import FleetConfig
from relay.control.fleet_peer import FleetPeer, OnEstop, OnLease, PeerLeases, RemoteLease
from relay.fleet.events import EventSink
from relay.station.core import Relay
from tests.helpers.station import Clock, FakeBackend, Station


class FakePeer:
    relay_id = "here"

    def __init__(self) -> None:
        self.estops: list[tuple[str | None, str | None]] = []
        self.leases: list[tuple[str, str | None]] = []
        self.elsewhere: dict[str, RemoteLease] = {}
        self.on_estop: OnEstop | None = None
        self.on_lease: OnLease | None = None

    def attach(self, on_estop: OnEstop, on_lease: OnLease) -> None:
        self.on_estop, self.on_lease = on_estop, on_lease

    def held_elsewhere(self, robot: str) -> RemoteLease | None:
        return self.elsewhere.get(robot)

    def lease_changed(self, robot: str, holder: str | None) -> None:
        self.leases.append((robot, holder))

    def estop(self, robot: str | None, by: str | None) -> None:
        self.estops.append((robot, by))


class PeeredBackend(FakeBackend):
    def __init__(self, config: FleetConfig, sink: EventSink, peer: FakePeer) -> None:
        super().__init__(config, sink)
        self.peer = peer

    def fleet_peer(self) -> FleetPeer:
        return self.peer


@pytest.fixture
async def peered(fleet_config: FleetConfig, tmp_path: Path) -> Any:
    clock, peer = Clock(), FakePeer()
    holder: dict[str, PeeredBackend] = {}

    def factory(config: FleetConfig, sink: EventSink, options: Options) -> Backend:
        holder["backend"] = PeeredBackend(config, sink, peer)
        return holder["backend"]

    relay = Relay(fleet_config, Options(audit_log=str(tmp_path / "audit.jsonl")), backend_factory=factory, clock=clock)
    await relay.backend.start()
    yield Station(relay, holder["backend"], clock), peer
    await relay.stop()


async def carried_out(station: Station) -> None:
    """The stops another relay's estop started here are done, and their messages sent."""
    await asyncio.gather(*station.relay.control._remote_stops)
    await station.settle()


async def test_an_estop_here_is_sent_to_the_other_relays_and_theirs_latch_here(peered: Any) -> None:
    station, peer = peered
    client, seen = station.connect()
    await station.send(client, {"identifier": "estop", "id": 1})
    assert peer.estops == [(None, client.client_id)]
    await station.send(client, {"identifier": "estop", "id": 2, "action": "reset"})
    assert peer.estops == [(None, client.client_id)]  # a reset is this relay's own
    # Another relay's estop of robot2: latched and stopped here, not sent back out.
    assert peer.on_estop is not None
    peer.on_estop("robot2", "op-7 via relay there")
    await carried_out(station)
    await station.send(client, {"identifier": "robot2/cmd_vel", "id": 3, "linear": 0.2, "angular": 0.0})
    assert seen.replies(3)[0]["code"] == "estopped" and "op-7 via relay there" in seen.replies(3)[0]["message"]
    assert station.backend.moves("robot2")[-1] == ("velocity", "robot2", 0.0, 0.0)
    assert seen.of("estop")[-1]["robots"] == ["robot2"]
    assert peer.estops == [(None, client.client_id)]
    await station.send(client, {"identifier": "robot1/cmd_vel", "id": 4, "linear": 0.2, "angular": 0.0})
    assert seen.replies(4)[0]["identifier"] == "ack"  # robot1 was not named


async def test_a_remote_estop_of_a_robot_this_relay_does_not_serve_changes_nothing(peered: Any) -> None:
    station, peer = peered
    _client, seen = station.connect()
    peer.on_estop("robot9", "someone")
    await carried_out(station)
    assert station.relay.control.latched == {} and seen.of("estop") == []


async def test_a_robot_leased_through_another_relay_refuses_commands_naming_the_holder(peered: Any) -> None:
    station, peer = peered
    client, seen = station.connect()
    # Renewed by relay "there" until 2026-01-01 12:00:09 UTC: the refusal says until when.
    peer.elsewhere["robot1"] = RemoteLease("robot1", "there", "op-7", until=1_767_268_809.0, remaining=8.2)
    commands: list[dict[str, Any]] = [
        {"identifier": "robot1/cmd_vel", "linear": 0.2, "angular": 0.0},
        {"identifier": "robot1/goal_pose", "x": 3.0, "y": 2.0},
        {"identifier": "robot1/lease"},
        {"identifier": "robot1/lease", "force": True},
    ]
    for i, message in enumerate(commands, start=1):
        await station.send(client, {**message, "id": i})
        reply = seen.replies(i)[0]
        assert reply["code"] == "leased" and "op-7 through relay there" in reply["message"], reply
        assert "until 12:00:09 UTC (in 9 s) unless relay there renews it" in reply["message"], reply
    assert station.backend.moves("robot1") == [] and peer.leases == []
    # Released there: this relay's operator takes it, and the others are told.
    del peer.elsewhere["robot1"]
    await station.send(client, {"identifier": "robot1/lease", "id": 9})
    assert seen.replies(9) == [{"identifier": "ack", "id": 9}]
    assert peer.leases == [("robot1", client.client_id)]
    await station.send(client, {"identifier": "robot1/lease", "id": 10, "action": "release"})
    assert peer.leases[-1] == ("robot1", None)


async def test_who_holds_a_robot_through_another_relay_is_every_clients_status(peered: Any) -> None:
    station, peer = peered
    _client, seen = station.connect()
    peer.on_lease("robot3", "op-7 through relay there")
    await station.settle()
    assert station.relay.fleet.status("robot3", station.clock.now)["controller"] == "op-7 through relay there"
    assert seen.of("robot3/status")[-1]["controller"] == "op-7 through relay there"
    peer.on_lease("robot3", None)
    await station.settle()
    assert station.relay.fleet.status("robot3", station.clock.now)["controller"] is None


# -- the rule of leases held through other relays (relay/control/fleet_peer.py's PeerLeases), the time passed in
# ----------


def test_a_token_without_its_relays_heartbeat_holds_nothing() -> None:
    """A rogue session that declared a lease token blocked even a forced take-over for as long as it lived
    (issue 28, finding 6): a token counts only while its relay's heartbeats list the lease."""
    leases = PeerLeases(["robot1", "robot2"], timeout=10.0)
    leases.token("robot1", "rogue", "c1", present=True)
    assert leases.lease("robot1", 0.0, 1000.0) is None and leases.changes(0.0) == {}
    # A heartbeat that lists another client, or another robot, does not vouch for this token either.
    leases.heartbeat("rogue", {"robot1": "c2", "robot2": "c1"}, 0.0)
    assert leases.lease("robot1", 0.0, 1000.0) is None and leases.lease("robot2", 0.0, 1000.0) is None


def test_a_lease_lasts_the_timeout_after_its_relays_last_heartbeat() -> None:
    leases = PeerLeases(["robot1", "robot2"], timeout=10.0)
    leases.heartbeat("B", {"robot1": "c1"}, 5.0)  # the heartbeat may come before the token
    assert leases.lease("robot1", 5.0, 1000.0) is None
    leases.token("robot1", "B", "c1", present=True)
    assert leases.changes(5.0) == {"robot1": "c1 through relay B"}
    assert leases.changes(6.0) == {}  # told once
    lease = leases.lease("robot1", 9.0, 1004.0)
    assert lease == RemoteLease("robot1", "B", "c1", until=1010.0, remaining=6.0)
    assert lease is not None and lease.holder == "c1 through relay B"
    leases.heartbeat("B", {"robot1": "c1"}, 12.0)  # renewed
    assert leases.lease("robot1", 21.9, 0.0) is not None and leases.changes(21.9) == {}
    # Silent for the timeout: lapsed, and told once.
    assert leases.lease("robot1", 22.0, 0.0) is None
    assert leases.changes(22.0) == {"robot1": None} and leases.changes(23.0) == {}
    assert leases.relays(21.0) == 1 and leases.relays(22.0) == 0


def test_a_lease_ends_when_its_token_goes_or_its_relays_heartbeat_drops_it() -> None:
    leases = PeerLeases(["robot1", "robot2"], timeout=10.0)
    leases.heartbeat("B", {"robot1": "c1", "robot2": "c1"}, 0.0)
    leases.token("robot1", "B", "c1", present=True)
    leases.token("robot2", "B", "c1", present=True)
    assert leases.changes(0.0) == {"robot1": "c1 through relay B", "robot2": "c1 through relay B"}
    leases.token("robot1", "B", "c1", present=False)  # withdrawn: Zenoh says so at once when B's session ends
    leases.heartbeat("B", {"robot1": "c1"}, 1.0)  # released robot2: its token may still be on its way
    assert leases.changes(1.0) == {"robot1": None, "robot2": None}
    assert leases.listed("B") == {"robot1"} and leases.listed("C") == set()


def test_the_tables_are_bounded_and_keep_only_this_relays_robots() -> None:
    leases = PeerLeases(["robot1"], timeout=10.0, max_tokens=3, max_relays=2)
    assert leases.token("robot9", "B", "c1", present=True)  # not ours: nothing kept, nothing refused
    assert all(leases.token("robot1", f"R{i}", "c1", present=True) for i in range(3))
    assert not leases.token("robot1", "R3", "c1", present=True)
    assert leases.token("robot1", "R0", "c1", present=True)  # already known
    leases.token("robot1", "R0", "c1", present=False)
    assert leases.token("robot1", "R3", "c1", present=True)  # room again
    assert leases.heartbeat("R1", {"robot1": "c1", "robot9": "c1"}, 0.0) and leases.listed("R1") == {"robot1"}
    assert leases.heartbeat("R2", {}, 5.0)
    assert not leases.heartbeat("R3", {"robot1": "c1"}, 9.0)  # full of relays heard within the timeout
    assert leases.heartbeat("R3", {"robot1": "c1"}, 10.0)  # R1 is silent by now: it makes room
    # Two relays hold the same robot (a race): the lease that lapses last is the one shown.
    lease = leases.lease("robot1", 10.0, 0.0)
    assert lease is not None and lease.relay == "R3"
    leases.clear()
    assert leases.lease("robot1", 10.0, 0.0) is None and leases.relays(10.0) == 0


@given(
    st.lists(
        st.tuples(
            st.sampled_from(["token", "gone", "beat", "look"]),
            st.sampled_from(["robot1", "robot2", "robot9"]),
            st.sampled_from(["A", "B", "C"]),
            st.sampled_from(["c1", "c2"]),
            st.floats(min_value=0.0, max_value=100.0),
        ),
        max_size=60,
    )
)
def test_no_lease_outlives_its_relays_last_heartbeat_listing_it(events: list[tuple[str, str, str, str, float]]) -> None:
    leases = PeerLeases(["robot1", "robot2"], timeout=10.0)
    last: dict[tuple[str, str, str], float] = {}  # (relay, robot, client) -> last heartbeat listing it
    now = 0.0
    for kind, robot, relay, client, step in events:
        now += step
        if kind == "token":
            leases.token(robot, relay, client, present=True)
        elif kind == "gone":
            leases.token(robot, relay, client, present=False)
        elif kind == "beat":
            leases.heartbeat(relay, {robot: client}, now)
            for key in [k for k in last if k[0] == relay]:
                del last[key]
            last[(relay, robot, client)] = now
        lease = leases.lease(robot, now, now)
        if lease is not None:
            assert now - last[(lease.relay, robot, lease.client)] < 10.0
            assert lease.remaining == pytest.approx(last[(lease.relay, robot, lease.client)] + 10.0 - now)
