"""What the relay lets out besides robot data (issue 28, finding 7): the database password in log lines, capture
images in the working directory. The relay runs as a user starts it (``python -m relay``), against a real
PostgreSQL server that asks for a password."""

from __future__ import annotations

import asyncio
import os
import secrets
import sys
from collections.abc import Iterator
from pathlib import Path

import aiohttp
import pytest

from tests.conftest import ROOT, RunningRelay
from tests.helpers.postgres import running_postgres
from tests.wsclient import TestClient

TOKEN = secrets.token_urlsafe(32)


@pytest.fixture(scope="module")
def password_server() -> Iterator[tuple[str, str]]:
    """A throwaway PostgreSQL server on 127.0.0.1 that asks for a password (scram-sha-256) of its user ``relay``:
    its URL without the password, and the password."""
    password = "pw-" + secrets.token_urlsafe(12)
    with running_postgres(password) as (url, _):
        yield url, password


async def _relay(database: str, cwd: Path, env: dict[str, str]) -> tuple[asyncio.subprocess.Process, str]:
    """``python -m relay`` as a user starts it, in ``cwd``; the process and the first line it printed."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", "--port", "0", "--config", str(ROOT / "robots.yaml"), f"--token={TOKEN}",
        "--database", database, "--audit-log", "", "--log-level", "debug", "--no-accounts",
        cwd=cwd, env=env, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )  # fmt: skip
    assert process.stdout is not None
    line = (await asyncio.wait_for(process.stdout.readline(), 60)).decode()
    return process, line


async def _output(process: asyncio.subprocess.Process) -> str:
    if process.returncode is None:
        # A relay that failed at start-up exits by itself: wait for that first. Terminating an exited child that
        # asyncio's watcher had not reaped yet reaps it in subprocess.Popen's poll, and the watcher then reports
        # "Unknown child process", exit status 255 (seen twice in three CI-like runs).
        try:
            await asyncio.wait_for(process.wait(), 1.0)
        except TimeoutError:
            process.terminate()
    out, err = await asyncio.wait_for(process.communicate(), 30)
    return out.decode() + err.decode()


async def test_the_database_password_never_reaches_a_log_line_and_images_stay_out_of_the_working_directory(
    password_server: tuple[str, str], tmp_path: Path
) -> None:
    """Measured before: with ``--database postgresql://user:PASSWORD@...`` the start-up log line carried the
    password in full, and with no ``--images`` capture images were written into the working directory. Now every
    log line has ``***`` for it (and libpq's PGPASSWORD keeps it out of the URL altogether), and the images go to
    ``~/.local/share/xr-relay/images``."""
    url, password = password_server
    home, cwd = tmp_path / "home", tmp_path / "cwd"
    home.mkdir()
    cwd.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PG")} | {"HOME": str(home)}
    relay, line = await _relay(url.replace("relay@", f"relay:{password}@"), cwd, env)
    try:
        assert "open " in line, line + await _output(relay)
        base = line.split("open ")[1].split("/#")[0]
        client = await TestClient.open(base.replace("http", "ws") + f"/ws?token={TOKEN}")
        await client.hello()
        await asyncio.sleep(0.5)  # the sim's first rendered frame
        added = await client.request(
            {"identifier": "target/add", "target": "spot-1", "robot": "robot1", "u": 240, "v": 360}, timeout=30
        )
        assert added["identifier"] == "ack", added
        finding = next(m for _, m in client.messages if m["identifier"] == "finding")
        await client.close()
    finally:
        log = await _output(relay)
    sha = finding["image"].removeprefix("/captures/").removesuffix(".jpg")
    assert (home / ".local" / "share" / "xr-relay" / "images" / sha[:2] / f"{sha}.jpg").is_file()
    assert list(cwd.iterdir()) == []
    # The start-up line names the database by the store's name: the URL without its password.
    assert password not in log and "database postgresql://relay@127.0.0.1" in log, log[-2000:]
    # The password from PGPASSWORD (libpq), the URL without it: the same relay, nothing to hide.
    relay, line = await _relay(url, cwd, env | {"PGPASSWORD": password})
    log = await _output(relay)
    assert "open " in line and password not in log, line + log[-2000:]
    # A wrong one: a clear refusal at start-up naming the database, and no password of either kind in it.
    wrong = "wrong-" + secrets.token_urlsafe(8)
    relay, line = await _relay(url.replace("relay@", f"relay:{wrong}@"), cwd, env | {"PGPASSWORD": password})
    log = line + await _output(relay)
    assert relay.returncode == 2 and "password authentication failed" in log, log[-2000:]
    assert wrong not in log and password not in log
    assert f"database {url} " in log


def test_redaction_covers_urls_parameters_and_tracebacks() -> None:
    from relay.logs.redaction import redact

    assert (
        redact("db postgresql://relay:p@ss:w%2Frd@db.example:5432/x ok")
        == "db postgresql://relay:***@db.example:5432/x ok"
    )
    assert redact("postgres://relay@db/x?sslmode=require&password=hunter2") == (
        "postgres://relay@db/x?sslmode=require&password=***"
    )
    assert redact("host=db password=hunter2 user=relay") == "host=db password=*** user=relay"
    assert redact("GET /ws?token=abc&batch=1") == "GET /ws?token=***&batch=1"
    for harmless in ("http://127.0.0.1:8080/path@x", "postgresql://relay@db:5432/x", "a note: 3 m @ 2 s"):
        assert redact(harmless) == harmless


async def test_every_response_carries_the_security_headers(relay_server: RunningRelay) -> None:
    """Measured before: no Content-Security-Policy, X-Content-Type-Options, Referrer-Policy or frame-ancestors on
    any page. Now every response has them, errors and refusals included; the page's import map is allowed by its
    hash and nothing else inline is (tests/e2e/test_security_headers.py loads the pages in Chromium)."""
    from relay.net.headers import inline_script_hashes

    import_map = inline_script_hashes((ROOT / "xr_client" / "index.html").read_text())
    assert len(import_map) == 1
    paths = {
        "/": 200, "/src/main.js": 200, "/scenes/facility.glb": 200, "/healthz": 200, "/metrics": 200,
        "/package.json": 404, "/report/m-nothing.html": 404, f"/captures/{'0' * 64}.jpg": 404, "/ws": 400,
    }  # fmt: skip
    async with aiohttp.ClientSession() as http:
        answers = []
        for path, status in paths.items():
            async with http.get(relay_server.url + path) as response:
                answers.append((path, response.status, status, response.headers))
        async with http.get(relay_server.url + "/", headers={"Host": "evil.example"}) as response:
            answers.append(("/ (rebinding)", response.status, 403, response.headers))
    for path, got, expected, headers in answers:
        assert got == expected, (path, got)
        assert headers.get("X-Content-Type-Options") == "nosniff", path
        assert headers.get("Referrer-Policy") == "no-referrer", path
        policy = dict(d.strip().split(" ", 1) for d in headers["Content-Security-Policy"].split(";"))
        assert policy["frame-ancestors"] == "'none'" and policy["object-src"] == "'none'", path
        assert policy["script-src"] == f"'self' 'wasm-unsafe-eval' {import_map[0]}", path
        assert "'unsafe-inline'" not in headers["Content-Security-Policy"], path
    host = relay_server.url.removeprefix("http://")
    assert policy["connect-src"] == "'self' blob: data:"  # the rebinding Host is not named
    assert (
        dict(d.strip().split(" ", 1) for d in answers[0][3]["Content-Security-Policy"].split(";"))["connect-src"]
        == f"'self' blob: data: ws://{host}"
    )
