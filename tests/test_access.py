"""Access and control: the operator token, viewers, the Origin check, failed-attempt limits, message rate
caps, control leases, and TLS. Every refusal is checked on the backend side too: nothing reaches a robot."""

from __future__ import annotations

import asyncio
import secrets
import ssl
import subprocess
import sys
import time
from asyncio.subprocess import PIPE
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from websockets.exceptions import InvalidStatus

from relay.cli.options import Options
from relay.config import FleetConfig
from relay.net.access import FIRST_DELAY, FREE_FAILURES
from relay.net.tls import ensure_certificate, fingerprint
from tests.conftest import ROOT, RunningRelay, relay_process, start_relay
from tests.helpers.spy import CommandSpy
from tests.wsclient import TestClient

TOKEN = "s3cret-operator-token"


@pytest.fixture
async def guarded(fleet_config: FleetConfig) -> AsyncIterator[RunningRelay]:
    running = await start_relay(fleet_config, options=Options(token=TOKEN, allow_viewers=False))
    try:
        yield running
    finally:
        await running.runner.cleanup()


async def refused_status(url: str, **kwargs: Any) -> int:
    with pytest.raises(InvalidStatus) as info:
        await TestClient.open(url, **kwargs)
    return info.value.response.status_code


async def test_token_is_required_and_checked(guarded: RunningRelay) -> None:
    spy = CommandSpy(guarded.relay.backend)  # type: ignore[arg-type]
    assert await refused_status(guarded.ws_url) == 401
    assert await refused_status(guarded.ws_url + "?token=wrong") == 401
    assert await refused_status(guarded.ws_url + "?token=" + TOKEN[:-1]) == 401
    client = await TestClient.open(guarded.ws_url + "?token=" + TOKEN)
    hello = await client.hello()
    assert hello["role"] == "operator"
    assert (await client.request({"identifier": "robot1/cmd_vel", "linear": 0.1, "angular": 0.0}))[
        "identifier"
    ] == "ack"
    assert spy.moving_commands() == [("send_velocity", ("robot1", 0.1, 0.0))]
    await client.close()


async def test_foreign_origin_is_refused_even_with_the_token(fleet_config: FleetConfig) -> None:
    running = await start_relay(
        fleet_config, options=Options(token=TOKEN, allowed_origins=("https://ops.example.org",))
    )
    try:
        url = running.ws_url + "?token=" + TOKEN
        assert await refused_status(url, origin="http://evil.example.com") == 403
        own = running.url  # the relay's own page: http://127.0.0.1:PORT
        for origin in (own, "https://ops.example.org"):
            client = await TestClient.open(url, origin=origin)
            assert (await client.hello())["role"] == "operator"
            await client.close()
        # Without Origin (a command-line tool) the token decides, as for anyone.
        assert await refused_status(running.ws_url) == 401
    finally:
        await running.runner.cleanup()


async def test_viewers_see_everything_and_command_nothing(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config, options=Options(token=TOKEN, allow_viewers=True))
    spy = CommandSpy(running.relay.backend)  # type: ignore[arg-type]
    try:
        viewer = await TestClient.open(running.ws_url)  # no token
        assert (await viewer.hello())["role"] == "viewer"
        await viewer.wait_for(lambda m: m["identifier"] == "robot1/pose")
        commands: list[dict[str, Any]] = [
            {"identifier": "robot1/goal_pose", "x": 3.0, "y": 6.0},
            {"identifier": "robot1/cmd_vel", "linear": 0.5, "angular": 0.0},
            {"identifier": "robot1/cancel"},
            {"identifier": "robot1/lease", "action": "acquire", "force": True},
            {"identifier": "estop"},
        ]
        for command in commands:
            reply = await viewer.request(command)
            assert reply["identifier"] == "error" and reply["code"] == "forbidden", reply
        # A wrong token is no better than none.
        wrong = await TestClient.open(running.ws_url + "?token=nope")
        assert (await wrong.hello())["role"] == "viewer"
        await asyncio.sleep(0.2)
        assert spy.calls == []
        await viewer.close()
        await wrong.close()
    finally:
        await running.runner.cleanup()


def test_wrong_tokens_are_slowed_and_the_right_token_always_gets_in() -> None:
    from relay.net.access import FIRST_DELAY, FREE_FAILURES, MAX_DELAY, Access, Refused

    access = Access(TOKEN)
    delays = []
    now = 100.0
    for _ in range(12):  # a guesser that waits for each answer before its next guess
        with pytest.raises(Refused) as refused:
            access.admit("guess", "127.0.0.1", now)
        delays.append(refused.value.delay)
        now += refused.value.delay + 0.01
    assert delays[:FREE_FAILURES] == [0.0] * FREE_FAILURES
    assert delays[FREE_FAILURES : FREE_FAILURES + 3] == [FIRST_DELAY, 2 * FIRST_DELAY, 4 * FIRST_DELAY]
    assert max(delays) == MAX_DELAY and delays == sorted(delays)
    # The right token, from the same address, right after: in at once (was: 429 for a minute).
    assert access.admit(TOKEN, "127.0.0.1", now) == ("operator", 0.0)
    # Another address is not slowed by this one, and a minute later this one is not either.
    with pytest.raises(Refused) as other:
        access.admit("guess", "10.0.0.2", now)
    assert other.value.delay == 0.0
    with pytest.raises(Refused) as later:
        access.admit("guess", "127.0.0.1", now + access.window + 15)
    assert later.value.delay == 0.0


def test_guesses_at_once_are_answered_one_after_another_and_ipv6_counts_by_its_64() -> None:
    """Each answer waiting on its own let 40 parallel guesses through within 0.02 s (issue 28, finding 5); the
    answers to one address's wrong tokens now come one after another, MAX_DELAY apart at the most."""
    from relay.net.access import MAX_DELAY, Access, Refused

    access = Access(TOKEN)
    answers = []
    for i in range(40):  # 40 wrong tokens at the same instant, from addresses of one IPv6 /64
        with pytest.raises(Refused) as refused:
            access.admit("guess", f"2001:db8:1:2::{i + 1:x}", 100.0)
        answers.append(100.0 + refused.value.delay)
    assert answers == sorted(answers) and len(set(answers[FREE_FAILURES:])) == 40 - FREE_FAILURES
    assert answers[-1] - 100.0 > 30 * MAX_DELAY  # 40 answers take over a minute, not 0.02 s
    assert access.admit(TOKEN, "2001:db8:1:2::99", 100.0) == ("operator", 0.0)
    with pytest.raises(Refused) as elsewhere:  # another /64 is another guesser
        access.admit("guess", "2001:db8:1:3::1", 100.0)
    assert elsewhere.value.delay == 0.0


async def test_a_page_spraying_tokens_cannot_lock_the_operator_out(guarded: RunningRelay) -> None:
    async with aiohttp.ClientSession() as http:
        # What <img src=".../ws?token=guess"> sends: no handshake, so the token is never even looked at.
        for _ in range(20):
            async with http.get(guarded.ws_url.replace("ws://", "http://") + "?token=guess") as response:
                assert response.status == 400
    # A browser's handshake always carries Origin: one without it (but with the browser's fetch headers) is forged.
    assert (
        await refused_status(guarded.ws_url + "?token=guess", additional_headers={"Sec-Fetch-Mode": "websocket"}) == 403
    )
    for _ in range(5):
        assert await refused_status(guarded.ws_url + "?token=guess") == 401
    client = await TestClient.open(guarded.ws_url + "?token=" + TOKEN)
    assert (await client.hello())["role"] == "operator"
    await client.close()


async def test_flood_is_rate_limited_but_estop_always_passes(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config, options=Options(max_message_rate=20.0))
    try:
        client = await TestClient.open(running.ws_url)
        await client.hello()
        for i in range(200):
            await client.send({"identifier": "robot1/cancel", "id": f"f{i}"})
        await client.send({"identifier": "estop", "id": "stop"})
        reply = await client.wait_for(lambda m: m.get("id") == "stop", timeout=10)
        assert reply["identifier"] == "ack"
        await client.wait_for(lambda m: m.get("id") == "f199", timeout=10)
        codes = [m.get("code") for _, m in client.messages if m["identifier"] == "error"]
        assert codes.count("rate_limited") >= 150  # a burst of 40 passes, the rest is dropped
        assert set(codes) == {"rate_limited"}
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_deep_or_huge_json_is_refused(relay_server: RunningRelay) -> None:
    client = await TestClient.open(relay_server.ws_url)
    await client.hello()
    deep = '{"identifier": "ping", "t": 1, "x": ' + "[" * 20 + "]" * 20 + "}"
    long_string = '{"identifier": "ping", "t": 1, "x": "' + "y" * 5000 + '"}'
    for frame in (deep, long_string):
        start = len(client.messages)
        await client.send_raw(frame)
        error = await client.wait_for(lambda m: m["identifier"] == "error", start=start)
        assert error["code"] == "bad_request"
    await client.close()


async def test_two_operators_race_for_one_robot(relay_server: RunningRelay) -> None:
    a = await TestClient.open(relay_server.ws_url)
    b = await TestClient.open(relay_server.ws_url)
    a_id, b_id = (await a.hello())["client_id"], (await b.hello())["client_id"]
    replies = await asyncio.gather(
        a.request({"identifier": "robot3/goal_pose", "x": 15.0, "y": 6.0}),
        b.request({"identifier": "robot3/goal_pose", "x": 15.0, "y": 5.0}),
    )
    outcomes = sorted(r["identifier"] for r in replies)
    assert outcomes == ["ack", "error"]
    winner, loser = (a_id, b_id) if replies[0]["identifier"] == "ack" else (b_id, a_id)
    refused = next(r for r in replies if r["identifier"] == "error")
    assert refused["code"] == "leased" and winner in refused["message"]
    status = await a.wait_for(lambda m: m["identifier"] == "robot3/status" and m["controller"] is not None)
    assert status["controller"] == winner
    # The loser cannot drive it either, and nothing of theirs reached it.
    loser_client = b if loser == b_id else a
    reply = await loser_client.request({"identifier": "robot3/cmd_vel", "linear": 0.3, "angular": 0.0})
    assert reply["code"] == "leased"
    await a.close()
    await b.close()


async def test_forced_takeover_stops_the_robot_first(relay_server: RunningRelay) -> None:
    spy = CommandSpy(relay_server.relay.backend)  # type: ignore[arg-type]
    a = await TestClient.open(relay_server.ws_url)
    b = await TestClient.open(relay_server.ws_url)
    a_id, b_id = (await a.hello())["client_id"], (await b.hello())["client_id"]
    for _ in range(6):
        await a.send({"identifier": "robot1/cmd_vel", "linear": 0.5, "angular": 0.0})
        await asyncio.sleep(0.05)
    assert (await b.request({"identifier": "robot1/lease"}))["code"] == "leased"
    taken_at = time.monotonic()
    assert (await b.request({"identifier": "robot1/lease", "force": True}))["identifier"] == "ack"
    notice = await a.wait_for(lambda m: m["identifier"] == "robot1/lease" and m["reason"] == "taken_over")
    assert (notice["holder"], notice["previous"]) == (b_id, a_id)
    # The robot got a zero velocity (and its goal cancelled) as the lease changed hands.
    stops = [(t, n, args) for t, n, args in spy.calls if t >= taken_at]
    assert ("send_velocity", ("robot1", 0.0, 0.0)) in [(n, args) for _, n, args in stops]
    # The previous holder is now refused; the new one drives.
    assert (await a.request({"identifier": "robot1/cmd_vel", "linear": 0.5, "angular": 0.0}))["code"] == "leased"
    reply = await b.request({"identifier": "robot1/cmd_vel", "linear": 0.2, "angular": 0.0})
    assert reply["identifier"] == "ack"
    await b.wait_for(lambda m: m["identifier"] == "robot1/status" and m["controller"] == b_id and m["mode"] == "teleop")
    # Release: the robot stops and anyone may take it.
    assert (await b.request({"identifier": "robot1/lease", "action": "release"}))["identifier"] == "ack"
    assert (await a.request({"identifier": "robot1/cancel"}))["identifier"] == "ack"
    await a.close()
    await b.close()


async def test_idle_lease_expires(fleet_config: FleetConfig) -> None:
    running = await start_relay(fleet_config, options=Options(lease_timeout=0.5))
    try:
        a = await TestClient.open(running.ws_url)
        b = await TestClient.open(running.ws_url)
        await a.hello()
        await b.hello()
        assert (await a.request({"identifier": "robot2/cancel"}))["identifier"] == "ack"
        assert (await b.request({"identifier": "robot2/cancel"}))["code"] == "leased"
        await b.wait_for(lambda m: m["identifier"] == "robot2/lease" and m["reason"] == "expired", timeout=5)
        assert (await b.request({"identifier": "robot2/cancel"}))["identifier"] == "ack"
        await a.close()
        await b.close()
    finally:
        await running.runner.cleanup()


def test_self_signed_certificate_is_created_once_and_reused(tmp_path: Path) -> None:
    cert, key = ensure_certificate(tmp_path, ("relay.lan",))
    first = fingerprint(cert)
    again, _ = ensure_certificate(tmp_path, ("relay.lan",))
    assert fingerprint(again) == first  # reused: a headset that accepted it keeps accepting it
    assert key.stat().st_mode & 0o077 == 0
    _, _ = ensure_certificate(tmp_path, ("other.lan",))
    assert fingerprint(cert) != first  # a name it does not cover: renewed


async def test_relay_serves_https_and_wss_with_tls_auto(tmp_path: Path) -> None:
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", "--tls", "auto", "--tls-dir", str(tmp_path), "--port", "0",
        "--audit-log", "", "--no-accounts", cwd=ROOT, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )  # fmt: skip
    try:
        assert process.stdout is not None
        line = (await asyncio.wait_for(process.stdout.readline(), 30)).decode()
        assert "open https://127.0.0.1:" in line and "#token=" in line
        base, token = line.split("open ")[1].split()[0].rstrip("/").split("/#token=")
        printed = (await asyncio.wait_for(process.stdout.readline(), 10)).decode()
        assert fingerprint(tmp_path / "xr-relay-cert.pem") in printed
        context = ssl.create_default_context(cafile=str(tmp_path / "xr-relay-cert.pem"))
        async with aiohttp.ClientSession() as http, http.get(f"{base}/healthz", ssl=context) as response:
            assert (await response.json())["backend"] == "sim"
        client = await TestClient.open(base.replace("https", "wss") + f"/ws?token={token}", ssl=context)
        assert (await client.hello())["role"] == "operator"
        await client.close()
    finally:
        process.terminate()
        await process.wait()


def test_token_never_reaches_the_logs(tmp_path: Path) -> None:
    """The relay logs refusals and connections without the query string that carries the token."""
    token = "tok-SECRET-" + secrets.token_urlsafe(32)
    script = (
        "import asyncio, sys\n"
        "from relay.cli.main import main\n"
        f"sys.exit(main(['--port', '0', '--token', {token!r}, '--log-level', 'debug', '--audit-log', '',\n"
        "'--no-accounts']))\n"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", script], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout is not None
        line = process.stdout.readline()
        base = line.split("open ")[1].split("/#")[0]
        import websockets.sync.client as sync_client

        for presented in (token, "wrong-SECRET-guess"):
            try:
                with sync_client.connect(base.replace("http", "ws") + f"/ws?token={presented}") as ws:
                    ws.recv(timeout=5)
            except Exception:
                pass
    finally:
        process.terminate()
        _, err = process.communicate(timeout=10)
    assert "connected as operator" in err and "refused a connection" in err
    assert "SECRET" not in err


async def test_the_page_can_ask_why_its_token_is_refused(fleet_config: FleetConfig) -> None:
    # Browsers hide a refused handshake's status; POST /auth answers under the same rules, so a stale tab stops.
    running = await start_relay(fleet_config, options=Options(token=TOKEN))
    try:
        async with aiohttp.ClientSession() as http:
            async with http.post(running.url + "/auth", data=TOKEN) as response:
                assert response.status == 200 and (await response.json()) == {"role": "operator"}
            async with http.post(running.url + "/auth", data="stale") as response:
                assert response.status == 401 and "wrong operator token" in await response.text()
            async with http.post(running.url + "/auth", data="") as response:
                assert response.status == 401 and "token is required" in await response.text()
            foreign = {"Origin": "https://evil.example"}
            async with http.post(running.url + "/auth", data=TOKEN, headers=foreign) as response:
                assert response.status == 403  # another site learns nothing, not even whether a token is right
            async with http.post(running.url + "/auth", data="x" * 5000) as response:
                assert response.status == 400
            # Wrong tokens here are slowed like wrong handshakes; the right one is never slowed.
            for _ in range(FREE_FAILURES + 2):
                async with http.post(running.url + "/auth", data="guess") as response:
                    assert response.status == 401
            started = time.monotonic()
            async with http.post(running.url + "/auth", data="guess") as response:
                assert response.status == 401
            assert time.monotonic() - started >= FIRST_DELAY * 4 * 0.9
            started = time.monotonic()
            async with http.post(running.url + "/auth", data=TOKEN) as response:
                assert response.status == 200
            assert time.monotonic() - started < FIRST_DELAY
    finally:
        await running.runner.cleanup()


async def test_guessing_at_report_is_slowed_as_at_the_handshake_and_learns_nothing(guarded: RunningRelay) -> None:
    """Measured before (issue 28, finding 5): 40 wrong tokens at /report were answered within 0.02 s, a wrong token
    got 401 where the right one got 404 (an oracle), and a 4-digit token was found so in 3.5 s. Now /report and
    /captures ask what the handshake asks (one count of wrong tokens per address, answers one after another) and
    answer a wrong token, no token, a foreign origin and an unknown name with the same 404."""
    async with aiohttp.ClientSession() as http:

        async def get(path: str, headers: dict[str, str] | None = None) -> tuple[int, str, str]:
            async with http.get(guarded.url + path, headers=headers) as response:
                return response.status, response.content_type, await response.text()

        unknown = await get(f"/report/m-nothing.html?token={TOKEN}")
        assert unknown[0] == 404
        assert await get("/report/m-nothing.html") == unknown
        assert await get("/report/m-nothing.html?token=guess") == unknown
        assert await get(f"/report/m-nothing.html?token={TOKEN}", {"Origin": "https://evil.example"}) == unknown
        image = await get(f"/captures/{'0' * 64}.jpg?token={TOKEN}")
        assert image[0] == 404 and await get(f"/captures/{'0' * 64}.jpg?token=guess") == image
        # Two wrong tokens so far from this address; 40 more at once.
        guesses = [asyncio.ensure_future(get(f"/report/m-{i}.csv?token=guess-{i}")) for i in range(40)]
        await asyncio.sleep(0.5)
        started = time.monotonic()
        assert (await get(f"/report/m-nothing.csv?token={TOKEN}"))[0] == 404  # the operator is not slowed
        # Behind the guesses it would wait over a minute (40 answers 0.1 s to 2 s apart); 5 s is a loaded CI's margin.
        assert time.monotonic() - started < 5.0
        done, pending = await asyncio.wait(guesses, timeout=3.0)
        # 0.1 + 0.2 + 0.4 + 0.8 s apart after the free ones: 5 answered within 3 s (all 40 within 0.02 s before).
        assert 1 <= len(done) <= 10, len(done)
        assert all(task.result()[:2] == unknown[:2] for task in done)
        for task in pending:
            task.cancel()
        await asyncio.gather(*pending, return_exceptions=True)
    # The same count as the handshake's: a wrong handshake from here now waits behind those guesses.
    with pytest.raises(TimeoutError):
        await asyncio.wait_for(refused_status(guarded.ws_url + "?token=guess"), 1.0)
    client = await TestClient.open(guarded.ws_url + "?token=" + TOKEN)
    assert (await client.hello())["role"] == "operator"
    await client.close()


def test_a_weak_token_is_refused_with_a_clear_message(caplog: pytest.LogCaptureFixture, monkeypatch: Any) -> None:
    """A 4-digit token was found through /report in 3.5 s and then opened /ws as operator (issue 28, finding 5):
    --token and $XR_RELAY_TOKEN refuse a token under 128 bits (estimated from its length and alphabet)."""
    from relay.cli.main import main
    from relay.net.access import weak_token

    monkeypatch.delenv("XR_RELAY_TOKEN", raising=False)
    assert main(["--token", "4821", "--audit-log", ""]) == 2
    assert "--token: the operator token has about 12 bits of entropy (4 characters)" in caplog.text
    assert "--allow-weak-token" in caplog.text and "secrets.token_urlsafe(32)" in caplog.text
    caplog.clear()
    monkeypatch.setenv("XR_RELAY_TOKEN", "operator-secret")
    assert main(["--audit-log", ""]) == 2
    assert "$XR_RELAY_TOKEN: the operator token has about" in caplog.text and "operator-secret" not in caplog.text
    # What the relay generates, and what the help suggests, always pass; so do 64 hexadecimal digits.
    assert all(weak_token(secrets.token_urlsafe(24)) is None for _ in range(2000))
    assert weak_token(secrets.token_urlsafe(32)) is None and weak_token(secrets.token_hex(32)) is None
    assert all(weak_token(t) is not None for t in ("a" * 200, "ab" * 100, "password" * 8, "0123456789" * 20))


async def test_a_weak_token_is_accepted_only_when_asked_and_said_loudly() -> None:
    relay, base = await relay_process("--token", "4821", "--allow-weak-token", "--audit-log", "", stderr=PIPE)
    try:
        client = await TestClient.open(base.replace("http", "ws") + "/ws?token=4821")
        assert (await client.hello())["role"] == "operator"
        await client.close()
    finally:
        relay.terminate()
        _, err = await relay.communicate()
    assert "WEAK OPERATOR TOKEN, accepted because of --allow-weak-token: --token has about 12 bits" in err.decode()
