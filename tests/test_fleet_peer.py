"""Control with another relay of the fleet behind a FleetPeer (relay/fleet_peer.py), without sockets: a fake peer
records what this relay tells the others and plays what they would tell it. tests/test_zenoh_fleet.py runs the same
over a real Zenoh router with two real relays.
"""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import pytest

from relay.backends.base import Backend
from relay.config import FleetConfig
from relay.core import Relay
from relay.events import EventSink
from relay.fleet_peer import FleetPeer, OnEstop, OnLease
from relay.options import Options
from tests.test_commands import Clock, FakeBackend, Station


class FakePeer:
    relay_id = "here"

    def __init__(self) -> None:
        self.estops: list[tuple[str | None, str | None]] = []
        self.leases: list[tuple[str, str | None]] = []
        self.elsewhere: dict[str, str] = {}
        self.on_estop: OnEstop | None = None
        self.on_lease: OnLease | None = None

    def attach(self, on_estop: OnEstop, on_lease: OnLease) -> None:
        self.on_estop, self.on_lease = on_estop, on_lease

    def held_elsewhere(self, robot: str) -> str | None:
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
    peer.elsewhere["robot1"] = "op-7 through relay there"
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
