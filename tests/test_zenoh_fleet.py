"""Two relays, one fleet, over one Zenoh router on 127.0.0.1: relay A in this process, relay B in a process of its
own (so that it can be killed). A lease held through B refuses A's commands, naming B's operator and relay; an
estop on A stops and latches the robots on B; once B is killed its lease goes with it and A's operator takes the
robot. tests/test_zenoh_backend.py has the router and the robots' side.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import ipaddress
import json
import math
import signal
import time
from pathlib import Path
from typing import Any

import orjson
import pytest

pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed: `pip install '.[zenoh]'`")

from relay.cli.options import Options, ZenohOptions
from relay.config import load_config, parse_config
from tests.conftest import ROOT, relay_process, start_relay
from tests.helpers.zenoh import FLEET, ODOM, Router, decode, demo_fleet_over_zenoh, until, zenoh_relay
from tests.wsclient import TestClient
from tests.zenoh_robots import attachment, free_port, key, odometry_by_hand

pytestmark = pytest.mark.slow


async def test_estop_and_leases_are_shared_by_two_relays_and_a_killed_relay_frees_its_robot(
    router: Router,
    tmp_path: Path,
) -> None:
    twists = router.listen("0/alpha/cmd_vel/*/*")
    config = tmp_path / "fleet.yaml"
    config.write_text(FLEET)
    relay_b, base_b = await relay_process(
        "--backend", "zenoh", "--config", str(config), "--zenoh-connect", router.endpoint, "--relay-id", "B",
        "--token", "t", "--allow-weak-token", "--audit-log", "", "--database", str(tmp_path / "b.sqlite"),
    )  # fmt: skip
    running_a = await zenoh_relay(router, relay_id="A")
    client_a = await TestClient.open(running_a.ws_url)
    client_b = await TestClient.open(base_b.replace("http", "ws") + "/ws?token=t")
    try:
        await client_a.hello()
        await client_b.hello()
        # B's operator drives alpha: B holds its lease, and its token reaches A.
        reply = await client_b.request({"identifier": "alpha/cmd_vel", "linear": 0.2, "angular": 0.0})
        assert reply["identifier"] == "ack", reply
        deadline = time.monotonic() + 10
        while True:
            reply = await client_a.request({"identifier": "alpha/cmd_vel", "linear": 0.1, "angular": 0.0})
            if reply["identifier"] == "error" or time.monotonic() > deadline:
                break
            await asyncio.sleep(0.1)  # the token is still on its way: A took the lease meanwhile, and gives it back
            await client_a.request({"identifier": "alpha/lease", "action": "release"})
        assert reply["identifier"] == "error" and reply["code"] == "leased", reply
        assert "through relay B" in reply["message"], reply
        assert (await client_a.request({"identifier": "alpha/lease"}))["code"] == "leased"
        assert (await client_a.request({"identifier": "alpha/lease", "force": True}))["code"] == "leased"

        # An estop on A stops and latches alpha and beta on B too.
        start = len(twists.all())
        reply = await client_a.request({"identifier": "estop"})
        assert reply["identifier"] == "ack", reply
        estop = await client_b.wait_for(lambda m: m["identifier"] == "estop" and m.get("latched", True), timeout=5)
        assert set(estop["robots"]) == {"alpha", "beta"} and "via relay A" in str(estop["by"])
        reply = await client_b.request({"identifier": "alpha/cmd_vel", "linear": 0.2, "angular": 0.0})
        assert reply["identifier"] == "error" and reply["code"] == "estopped", reply
        # Both relays sent alpha a zero Twist (their own publishers: two GIDs in the attachments).
        gids = {
            extra[17:] for _, payload, extra in twists.all()[start:] if extra and not decode(payload, TWIST).linear.x
        }
        assert len(gids) == 2, gids

        # B dies without a word: its lease token goes with its session, and A's operator takes alpha.
        relay_b.send_signal(signal.SIGKILL)
        await relay_b.wait()
        deadline = time.monotonic() + 15
        while (reply := await client_a.request({"identifier": "alpha/lease"}))["identifier"] != "ack":
            assert time.monotonic() < deadline, reply
            await asyncio.sleep(0.2)
    finally:
        await client_a.close()
        await running_a.runner.cleanup()


TWIST = "geometry_msgs/msg/Twist"
ESTOP_KEY = "xr_relay/estop"


def distance(a: dict[str, Any] | None, b: dict[str, Any] | None) -> float:
    assert a is not None and b is not None
    return math.hypot(a["x"] - b["x"], a["y"] - b["y"])


async def kill_if_running(process: asyncio.subprocess.Process) -> None:
    if process.returncode is None:
        process.kill()
        await process.wait()


async def test_a_killed_relays_robot_is_stopped_by_its_watchdog_and_freed_for_the_other_relay(tmp_path: Path) -> None:
    """The demo fleet over Zenoh (tools/fake_fleet_zenoh.py: robots with cmd_vel.watchdog, the watchdog's rules on
    the robots' side): relay B drives robot2 and is killed mid-drive; the heartbeat stops, the watchdog stops robot2
    (relay A sees it stand still), and A's operator gets robot2's lease."""
    async with contextlib.AsyncExitStack() as stack:
        endpoint = await stack.enter_async_context(demo_fleet_over_zenoh())
        relay_b, base_b = await relay_process(
            "--backend", "zenoh", "--config", str(ROOT / "robots.yaml"), "--zenoh-connect", endpoint,
            "--relay-id", "B", "--token", "t", "--allow-weak-token", "--audit-log", "",
            "--database", str(tmp_path / "b.sqlite"),
        )  # fmt: skip
        stack.push_async_callback(kill_if_running, relay_b)
        options = Options(backend="zenoh", zenoh=ZenohOptions(connect=(endpoint,), relay_id="A"))
        running_a = await start_relay(load_config(ROOT / "robots.yaml"), options=options)
        client_a = await TestClient.open(running_a.ws_url)
        client_b = await TestClient.open(base_b.replace("http", "ws") + "/ws?token=t")
        try:
            await client_a.hello()
            await client_b.hello()
            await until(lambda: client_a.pose("robot2"), 10, "robot2's pose on relay A")
            # B's operator drives robot2 (through its watchdog) until A sees it move.
            start = client_a.pose("robot2")
            assert start is not None
            deadline = time.monotonic() + 10
            while distance(client_a.pose("robot2"), start) < 0.2:
                assert time.monotonic() < deadline, "robot2 did not move"
                await client_b.send({"identifier": "robot2/cmd_vel", "linear": 0.4, "angular": 0.0})
                await asyncio.sleep(0.05)
            relay_b.send_signal(signal.SIGKILL)
            killed = time.monotonic()
            await relay_b.wait()
            # Stopped by the watchdog (relay A sends robot2 nothing): its pose stands still for a second.
            still_since, last = time.monotonic(), client_a.pose("robot2")
            while time.monotonic() - still_since < 1.0:
                assert time.monotonic() - killed < 5, "robot2 kept moving after its relay died"
                await asyncio.sleep(0.1)
                now = client_a.pose("robot2")
                if distance(now, last) > 0.005:
                    still_since, last = time.monotonic(), now
            deadline = time.monotonic() + 15
            while (reply := await client_a.request({"identifier": "robot2/lease"}))["identifier"] != "ack":
                assert time.monotonic() < deadline, reply
                await asyncio.sleep(0.2)
        finally:
            await client_a.close()
            await running_a.runner.cleanup()


# -- the fleet's keys for relays only: TLS, a user per relay, and the router's access control (docs/zenoh.md) -------


def documented(name: str) -> str:
    """The JSON5 file docs/zenoh.md shows under ``<!-- tested: NAME -->``, as written there."""
    text = (ROOT / "docs" / "zenoh.md").read_text()
    start = text.index(f"<!-- tested: {name} -->\n```json5\n") + len(f"<!-- tested: {name} -->\n```json5\n")
    return text[start : text.index("\n```", start)]


def certificates(directory: Path) -> tuple[Path, Path, Path]:
    """A CA, and the router's certificate for localhost and 127.0.0.1 signed by it: (ca, certificate, key)."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    def name(common: str) -> x509.Name:
        return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common)])

    now = datetime.datetime.now(datetime.UTC)
    ca_key, key = ec.generate_private_key(ec.SECP256R1()), ec.generate_private_key(ec.SECP256R1())

    def certificate(subject: str, public: Any, *, ca: bool) -> x509.CertificateBuilder:
        builder = (
            x509.CertificateBuilder()
            .subject_name(name(subject))
            .issuer_name(name("test fleet CA"))
            .public_key(public)
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=1))
            .add_extension(x509.BasicConstraints(ca=ca, path_length=None), critical=True)
        )
        if not ca:
            names = [x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]
            builder = builder.add_extension(x509.SubjectAlternativeName(names), critical=False)
        return builder

    paths = directory / "ca.pem", directory / "router.pem", directory / "router.key"
    ca = certificate("test fleet CA", ca_key.public_key(), ca=True).sign(ca_key, hashes.SHA256())
    leaf = certificate("localhost", key.public_key(), ca=False).sign(ca_key, hashes.SHA256())
    paths[0].write_bytes(ca.public_bytes(serialization.Encoding.PEM))
    paths[1].write_bytes(leaf.public_bytes(serialization.Encoding.PEM))
    private = serialization.PrivateFormat.PKCS8
    paths[2].write_bytes(key.private_bytes(serialization.Encoding.PEM, private, serialization.NoEncryption()))
    return paths


async def test_two_relays_over_tls_with_users_and_access_control_and_a_site_cannot_touch_the_fleet(
    tmp_path: Path,
) -> None:
    """docs/zenoh.md's router.json5 and relay.json5 as written (paths and port changed): relays ops-1 (here) and
    ops-2 (a process) share estop and leases over TLS through a router that asks every session for its user; a
    site's user gets its robot's pose through but its estop, heartbeat and lease token never reach a relay."""
    import zenoh

    ca, certificate, private_key = certificates(tmp_path)
    (tmp_path / "users.txt").write_text("ops-1:pw-1\nops-2:pw-2\nsite-a:pw-site\n")
    port = free_port()
    endpoint = f"tls/localhost:{port}"
    router_config = zenoh.Config.from_json5(documented("router.json5"))
    router_config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    tls = {
        "listen_certificate": str(certificate),
        "listen_private_key": str(private_key),
        "root_ca_certificate": str(ca),
    }
    for field, path in tls.items():
        router_config.insert_json5(f"transport/link/tls/{field}", json.dumps(path))
    router_config.insert_json5("transport/auth/usrpwd/dictionary_file", json.dumps(str(tmp_path / "users.txt")))
    ops_router = await asyncio.to_thread(zenoh.open, router_config)

    def relay_config(user: str, password: str) -> str:
        text = documented("relay.json5").replace("/etc/xr-relay/ca.pem", str(ca))
        text = text.replace('user: "ops-1", password: "CHANGE-ME"', f'user: "{user}", password: "{password}"')
        (tmp_path / f"{user}.json5").write_text(text)
        return str(tmp_path / f"{user}.json5")

    (tmp_path / "fleet.yaml").write_text(FLEET)
    relay_b, base_b = await relay_process(
        "--backend", "zenoh", "--config", str(tmp_path / "fleet.yaml"), "--zenoh-connect", endpoint,
        "--zenoh-config", relay_config("ops-2", "pw-2"), "--relay-id", "ops-2", "--token", "t", "--allow-weak-token",
        "--audit-log", "",
        "--database", str(tmp_path / "b.sqlite"),
    )  # fmt: skip
    options = Options(
        backend="zenoh", zenoh=ZenohOptions(connect=(endpoint,), config=relay_config("ops-1", "pw-1"), relay_id="ops-1")
    )
    running_a = await start_relay(parse_config(FLEET, "fleet.yaml"), options=options)
    client_a = await TestClient.open(running_a.ws_url)
    client_b = await TestClient.open(base_b.replace("http", "ws") + "/ws?token=t")
    site_config = zenoh.Config.from_file(relay_config("site-a", "pw-site"))
    site_config.insert_json5("mode", '"client"')
    site_config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    site_config.insert_json5("scouting/multicast/enabled", "false")
    site = await asyncio.to_thread(zenoh.open, site_config)
    try:
        await client_a.hello()
        await client_b.hello()
        # The site's user: its robot's pose reaches relay ops-1; its fleet samples are dropped by the router.
        block = zenoh.CongestionControl.BLOCK
        site.put(ESTOP_KEY, orjson.dumps({"relay": "R", "robot": None, "by": "c9"}), congestion_control=block)
        site.put(
            "xr_relay/heartbeat/R", orjson.dumps({"relay": "R", "leases": {"beta": "c9"}}), congestion_control=block
        )
        token: Any = site.liveliness().declare_token("xr_relay/lease/beta/R/c9")
        pose = odometry_by_hand(1_700_000_000, 0, "odom", "base_link", (2.0, 3.0, 0.0, 0.0, 0.0, 0.0, 1.0))
        deadline = time.monotonic() + 10
        while client_a.pose("alpha") is None:
            assert time.monotonic() < deadline, "the site's pose did not reach relay ops-1"
            site.put(key(*ODOM), pose, attachment=attachment(1))
            await asyncio.sleep(0.1)
        await asyncio.sleep(1.0)  # what the site sent on the fleet's keys would have arrived by now
        assert running_a.relay.control.latched == {}
        fleet = running_a.relay.backend.health()["zenoh"]["fleet"]  # type: ignore[index]
        assert fleet["refused"] == {"estop": 0, "heartbeat": 0, "lease": 0} and fleet["relays_heard"] == 1, fleet
        assert (await client_a.request({"identifier": "beta/lease"}))["identifier"] == "ack"
        assert (await client_a.request({"identifier": "beta/lease", "action": "release"}))["identifier"] == "ack"
        token.undeclare()

        # ops-2's operator drives alpha: ops-1 refuses it, naming the relay.
        assert (await client_b.request({"identifier": "alpha/cmd_vel", "linear": 0.2, "angular": 0.0}))[
            "identifier"
        ] == "ack"
        deadline = time.monotonic() + 10
        while (reply := await client_a.request({"identifier": "alpha/lease"}))["identifier"] != "error":
            assert time.monotonic() < deadline, reply
            await client_a.request({"identifier": "alpha/lease", "action": "release"})
            await asyncio.sleep(0.1)
        assert reply["code"] == "leased" and "through relay ops-2 until" in reply["message"], reply
        # An estop on ops-1 latches ops-2.
        assert (await client_a.request({"identifier": "estop"}))["identifier"] == "ack"
        estop = await client_b.wait_for(lambda m: m["identifier"] == "estop" and m.get("latched", True), timeout=5)
        assert set(estop["robots"]) == {"alpha", "beta"} and "via relay ops-1" in str(estop["by"])
    finally:
        await asyncio.to_thread(site.close)
        await client_a.close()
        await running_a.runner.cleanup()
        relay_b.kill()
        await relay_b.wait()
        await asyncio.to_thread(ops_router.close)
