"""Accounts and roles (issue #31): people sign in, and the relay knows who did what.

The rules without sockets (roles, sessions and pairing codes with a clock moved by hand, the users file), then a real
relay on a loopback port with a real users file: sign-in over HTTP, the session cookie on a real WebSocket, and
what each role may do, read back from the other pages and the audit log.
"""

from __future__ import annotations

import asyncio
import dataclasses
import re
import shutil
import sys
import time
from collections.abc import AsyncIterator
from pathlib import Path
from types import SimpleNamespace
from typing import cast

import orjson
import pytest

from relay.accounts.passwords import verify
from relay.accounts.roles import ROLES, may
from relay.accounts.sessions import CODE_LIFETIME, IDLE, LIFETIME, MAX_SESSIONS, Sessions
from relay.accounts.users import AccountError, UserBook
from relay.cli.options import Options
from relay.config import FleetConfig, parse_config
from relay.errors import ConfigError
from relay.net.access import FREE_FAILURES
from relay.net.account_watch import CLOSE_CODE as ACCOUNT_CHANGED
from relay.net.account_watch import PERIOD as WATCH_PERIOD
from tests.conftest import LOAD_SLACK, ROOT, RunningRelay, own_files, start_relay
from tests.helpers.people import Person
from tests.helpers.waiting import wait_until

MINIMAL = "robots:\n  - name: alpha\n    limits: {linear: 0.5, angular: 1.0}\n"
PASSWORDS = {
    "Ana": "ana-correct-horse",
    "Ben": "ben-battery-staple",
    "Ida": "ida-inspects-tanks",
    "Max": "max-drives-robots",
    "Root": "root-admin-pw",
}
ROLE_OF = {"Ana": "operator", "Ben": "viewer", "Ida": "inspector", "Max": "operator", "Root": "admin"}


# -- the rules ----------------------------------------------------------------------------------------


def test_each_role_may_what_the_issue_lists_and_nothing_more() -> None:
    table = {role: {p for p in ("drive", "stop", "reset", "inspect", "users") if may(role, p)} for role in ROLES}
    assert table == {
        "admin": {"drive", "stop", "reset", "inspect", "users"},
        "operator": {"drive", "stop", "reset", "inspect"},
        "inspector": {"stop", "inspect"},
        "viewer": set(),
    }


def test_sessions_end_when_idle_or_old_and_stay_bounded() -> None:
    sessions = Sessions()
    ana = sessions.open("Ana", "operator", 0.0)
    assert sessions.get(ana.id, IDLE - 1) is not None  # in use: its idle time restarts
    assert sessions.get(ana.id, 2 * IDLE - 2) is not None
    assert sessions.get(ana.id, LIFETIME + 1) is None  # a day after sign-in, whatever its use
    ben = sessions.open("Ben", "viewer", 0.0)
    assert sessions.get(ben.id, IDLE + 1) is None
    assert sessions.get("made-up", 0.0) is None and sessions.get(None, 0.0) is None
    first = sessions.open("Cy", "viewer", 0.0)
    for _ in range(MAX_SESSIONS):
        sessions.open("Cy", "viewer", 1.0)
    assert sessions.get(first.id, 2.0) is None  # the least recently used went


def test_a_pairing_code_gives_the_desktops_person_once_and_expires() -> None:
    sessions = Sessions()
    ana = sessions.open("Ana", "operator", 0.0)
    code = sessions.pairing_code(ana, 10.0)
    assert len(code) == 6 and code.isalnum()
    headset = sessions.claim(code.lower(), 20.0)  # typed in lower case on a headset's keyboard
    assert headset is not None and (headset.user, headset.role, headset.via) == ("Ana", "operator", "paired")
    assert headset.id != ana.id and headset.csrf != ana.csrf
    assert sessions.claim(code, 21.0) is None  # used up
    late = sessions.pairing_code(ana, 30.0)
    assert sessions.claim(late, 30.0 + CODE_LIFETIME + 1) is None
    replaced = sessions.pairing_code(ana, 40.0)
    newer = sessions.pairing_code(ana, 41.0)
    assert sessions.claim(replaced, 42.0) is None and sessions.claim(newer, 42.0) is not None
    signed_out = sessions.pairing_code(ana, 50.0)
    sessions.close(ana.id)
    assert sessions.claim(signed_out, 51.0) is None


def test_the_users_file_checks_names_passwords_and_keeps_an_admin(tmp_path: Path) -> None:
    book = UserBook(tmp_path / "users.sqlite")
    assert book.users() == [] and not (tmp_path / "users.sqlite").exists()  # reading makes no file
    book.add("Root", "admin", PASSWORDS["Root"])
    book.add("Ana", "operator", PASSWORDS["Ana"])
    with pytest.raises(AccountError, match="exists already"):
        book.add("ana", "viewer", "another-password")  # one account, whatever the case
    with pytest.raises(AccountError, match="at least 10 characters"):
        book.add("Cy", "viewer", "short")
    with pytest.raises(AccountError, match="user name"):
        book.add("<script>", "viewer", "long-enough-password")
    with pytest.raises(AccountError, match="none of admin, operator, inspector, viewer"):
        book.add("Cy", "superuser", "long-enough-password")
    with pytest.raises(AccountError, match="last admin"):
        book.remove("Root")
    with pytest.raises(AccountError, match="last admin"):
        book.set_role("root", "operator")
    assert [(u.name, u.role) for u in book.users()] == [("Ana", "operator"), ("Root", "admin")]
    found = book.hash_of("ANA")
    assert found is not None and found[0].name == "Ana" and found[1].startswith("$argon2id$")
    assert verify(found[1], PASSWORDS["Ana"]) and not verify(found[1], PASSWORDS["Ana"] + "x")
    assert not verify(None, PASSWORDS["Ana"])  # an unknown user: the dummy hash, never a match
    book.set_password("Ana", "a-new-password-1")
    again = book.hash_of("Ana")
    assert again is not None and verify(again[1], "a-new-password-1")


# -- a relay with accounts ----------------------------------------------------------------------------


def test_who_may_reset_is_a_setting_that_names_what_it_takes() -> None:
    config = parse_config(MINIMAL + "safety: {estop_reset: presser}\n", "robots.yaml")
    assert config.safety.estop_reset == "presser" and parse_config(MINIMAL).safety.estop_reset == "anyone"
    with pytest.raises(ConfigError, match=r"safety\.estop_reset"):
        parse_config(MINIMAL + "safety: {estop_reset: sometimes}\n", "robots.yaml")


@pytest.fixture
def presser_only(request: pytest.FixtureRequest) -> bool:
    return bool(getattr(request, "param", False))


@pytest.fixture(scope="module")
def users_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site's people, hashed once for the module (each Argon2id hash takes 64 MiB and up to a second here)."""
    book = UserBook(tmp_path_factory.mktemp("accounts") / "users.sqlite")
    for name, password in PASSWORDS.items():
        book.add(name, ROLE_OF[name], password)
    return book.path


@pytest.fixture
async def site(
    fleet_config: FleetConfig, tmp_path: Path, presser_only: bool, users_file: Path
) -> AsyncIterator[tuple[RunningRelay, Path]]:
    if presser_only:
        fleet_config = dataclasses.replace(
            fleet_config, safety=dataclasses.replace(fleet_config.safety, estop_reset="presser")
        )
    users = tmp_path / "users.sqlite"
    await asyncio.to_thread(shutil.copyfile, users_file, users)
    audit = tmp_path / "audit.jsonl"
    options = Options(users=str(users), audit_log=str(audit), database=str(tmp_path / "i.sqlite"))
    running = await start_relay(fleet_config, options=options)
    try:
        yield running, audit
    finally:
        await running.runner.cleanup()


@pytest.fixture
async def people(site: tuple[RunningRelay, Path]) -> AsyncIterator[dict[str, Person]]:
    made = {name: Person(site[0], PASSWORDS) for name in (*PASSWORDS, "Eve")}
    try:
        yield made
    finally:
        for person in made.values():
            await person.close()


async def test_who_pressed_estop_is_the_person_on_every_page_and_in_the_audit_log(
    site: tuple[RunningRelay, Path], people: dict[str, Person]
) -> None:
    _, audit = site
    assert (await people["Ana"].sign_in("ana", PASSWORDS["Ana"]))["user"] == "Ana"  # the account's own spelling
    await people["Ben"].sign_in("Ben")
    ana, ben = await people["Ana"].page(), await people["Ben"].page()
    assert ana.latest["hello"]["role"] == "operator" and ben.latest["hello"]["role"] == "viewer"
    reply = await ana.request({"identifier": "estop"})
    assert reply["identifier"] == "ack", reply
    latched = await ben.wait_for(lambda m: m["identifier"] == "estop" and m["latched"])
    roster = await ben.wait_for(lambda m: m["identifier"] == "operators" and latched["by"] in m["names"])
    assert roster["names"][latched["by"]] == "Ana"
    # A signed-in person cannot call themselves anything else.
    renamed = await ana.request({"identifier": "name", "name": "Ben"})
    assert renamed["code"] == "forbidden" and "signed in as Ana" in renamed["message"], renamed
    # Ben watches: he can neither stop nor reset, and says so in words.
    for action in ("press", "reset"):
        refused = await ben.request({"identifier": "estop", **({"action": "reset"} if action == "reset" else {})})
        assert refused["code"] == "forbidden" and "a viewer cannot" in refused["message"], refused
    records = [orjson.loads(line) for line in (await asyncio.to_thread(audit.read_text)).splitlines()]
    pressed = next(r for r in records if r["identifier"] == "estop" and r["outcome"] == "accepted")
    assert (pressed["user"], pressed["role"]) == ("Ana", "operator") and "name" not in pressed
    assert any(r.get("user") == "Ben" and r["outcome"] == "refused" for r in records)
    await ana.close()
    await ben.close()


async def test_an_inspector_stops_and_runs_inspection_but_neither_drives_nor_resets(
    site: tuple[RunningRelay, Path], people: dict[str, Person]
) -> None:
    await people["Ida"].sign_in("Ida")
    ida = await people["Ida"].page()
    robot = ida.latest["hello"]["robots"][0]["name"]
    drive = await ida.request({"identifier": f"{robot}/cmd_vel", "linear": 0.2, "angular": 0.0})
    assert drive["code"] == "forbidden" and "an inspector cannot command robots" in drive["message"], drive
    assert (await ida.request({"identifier": "estop"}))["identifier"] == "ack"
    reset = await ida.request({"identifier": "estop", "action": "reset"})
    assert reset["code"] == "forbidden" and "reset an E-STOP" in reset["message"], reset
    added = await ida.request({"identifier": "target/add", "target": "valve-7", "x": 2.0, "y": 2.0})
    assert added["identifier"] == "ack", added
    await ida.close()


async def test_wrong_passwords_are_slowed_and_never_say_which_part_was_wrong(
    site: tuple[RunningRelay, Path], people: dict[str, Person]
) -> None:
    eve = people["Eve"]
    unknown = await eve.post("/signin", {"user": "Nobody", "password": PASSWORDS["Ana"]})
    wrong = await eve.post("/signin", {"user": "Ana", "password": "not-her-password"})
    assert unknown == wrong == (401, "wrong user name or password\n")
    for _ in range(FREE_FAILURES):
        await eve.post("/signin", {"user": "Ana", "password": "still-wrong-pw"})
    started = time.monotonic()
    assert (await eve.post("/signin", {"user": "Ana", "password": "wrong-again"}))[0] == 401
    assert time.monotonic() - started >= 0.1  # past the free failures, each answer waits (relay/net/access.py)
    # No cookie, no token: the handshake asks to sign in.
    with pytest.raises(Exception, match="401"):
        await eve.page()
    # Another site's page cannot sign in through the operator's browser.
    async with eve.http.post(
        site[0].url + "/signin", data=b'{"user":"Ana","password":"x"}', headers={"Origin": "https://evil.example"}
    ) as response:
        assert response.status == 403


async def test_a_headset_paired_by_code_is_the_same_person_and_the_code_needs_the_csrf_token(
    site: tuple[RunningRelay, Path], people: dict[str, Person]
) -> None:
    ana, headset = people["Ana"], people["Eve"]
    await ana.sign_in("Ana")
    assert (await ana.post("/pair", csrf=False))[0] == 403  # a page of another site has the cookie, not the token
    status, body = await ana.post("/pair")
    assert status == 200 and len(body["code"]) == 6, body
    status, claimed = await headset.post("/pair/claim", {"code": body["code"]})
    assert status == 200 and (claimed["user"], claimed["role"]) == ("Ana", "operator"), claimed
    page = await headset.page()
    assert page.latest["hello"]["role"] == "operator"
    assert (await page.request({"identifier": "estop"}))["identifier"] == "ack"
    assert (await people["Ben"].post("/pair/claim", {"code": body["code"]}))[0] == 401  # once
    await page.close()
    # Signed out, the cookie no longer opens anything.
    assert (await ana.post("/signout"))[0] == 200
    async with ana.http.get(site[0].url + "/whoami") as response:
        assert await response.json() == {"accounts": True, "user": None, "oidc": None}


@pytest.mark.parametrize("presser_only", [True], indirect=True)
async def test_where_only_the_presser_resets_another_operator_is_told_whose_it_is(
    site: tuple[RunningRelay, Path], people: dict[str, Person]
) -> None:
    for name in ("Ana", "Max", "Root"):
        await people[name].sign_in(name)
    ana, max_, root = [await people[name].page() for name in ("Ana", "Max", "Root")]
    assert (await ana.request({"identifier": "estop"}))["identifier"] == "ack"
    refused = await max_.request({"identifier": "estop", "action": "reset"})
    assert refused["code"] == "forbidden" and "pressed by Ana: only they or an admin" in refused["message"], refused
    assert (await root.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"  # an admin may
    assert (await max_.request({"identifier": "estop"}))["identifier"] == "ack"
    assert (await max_.request({"identifier": "estop", "action": "reset"}))["identifier"] == "ack"  # the presser may
    for page in (ana, max_, root):
        await page.close()


async def test_the_first_start_makes_an_admin_prints_the_password_once_and_never_logs_it(tmp_path: Path) -> None:
    """A relay started on a users file that does not exist yet (a new site's first `make run`) makes the account
    admin, prints its password once on stdout and asks everyone to sign in (no token in the URL); the admin signs in
    with it. The second start on the same file prints no password; no log line holds it."""
    users, log = tmp_path / "users.sqlite", tmp_path / "stderr.log"
    outputs = []
    for start in range(2):
        with log.open("ab") as stderr:
            process = await asyncio.create_subprocess_exec(
                sys.executable, "-m", "relay", *own_files("--users", str(users)), "--port", "0", cwd=ROOT,
                stdout=asyncio.subprocess.PIPE, stderr=stderr,
            )  # fmt: skip
        assert process.stdout is not None
        lines = [(await asyncio.wait_for(process.stdout.readline(), 60)).decode() for _ in range(2 - start)]
        outputs.append(lines)
        url = lines[-1].split("open ")[1].split()[0]
        assert "#token=" not in url and "(sign in;" in lines[-1], lines
        if start == 0:
            match = re.search(r"made the account 'admin' \(admin\) in \S+, password (\S+) ", lines[0])
            assert match, lines[0]
            relay = cast(RunningRelay, SimpleNamespace(url=url.rstrip("/"), ws_url=url.replace("http", "ws") + "ws"))
            admin = Person(relay)
            try:
                assert (await admin.sign_in("admin", match.group(1)))["role"] == "admin"
                page = await admin.page()
                hello = await page.hello()
                await page.close()
                assert hello["role"] == "admin", hello
            finally:
                await admin.close()
            password = match.group(1)
        process.terminate()
        await process.wait()
    assert "password" not in "".join(outputs[1]), outputs[1]
    assert [u.name for u in UserBook(users).users()] == ["admin"]
    assert password not in log.read_text(), "the admin's password reached a log line"


async def test_a_user_removed_or_given_another_role_while_the_relay_runs_is_signed_out_and_their_pages_closed(
    site: tuple[RunningRelay, Path], people: dict[str, Person], tmp_path: Path
) -> None:
    """`xr-relay users remove Ana` in another process while Ana drives: within the watch's period her page is closed
    and her cookie no longer opens one; Ben, a viewer made operator, is signed out too and signs in as an operator.
    Max, whose account did not change, stays connected."""
    ana, ben, max_ = people["Ana"], people["Ben"], people["Max"]
    pages = {}
    for name, person in (("Ana", ana), ("Ben", ben), ("Max", max_)):
        await person.sign_in(name)
        pages[name] = await person.page()
    book = UserBook(tmp_path / "users.sqlite")
    await asyncio.to_thread(book.remove, "Ana")
    await asyncio.to_thread(book.set_role, "Ben", "operator")
    closed = lambda: bool(pages["Ana"].closed_code and pages["Ben"].closed_code)  # noqa: E731
    await wait_until(closed, 3 * WATCH_PERIOD + LOAD_SLACK, "Ana's and Ben's pages closed")
    assert pages["Ana"].closed_code == pages["Ben"].closed_code == ACCOUNT_CHANGED, pages
    assert pages["Max"].closed_code is None
    with pytest.raises(Exception, match="401"):
        await ana.page()
    assert (await ana.post("/signin", {"user": "Ana", "password": PASSWORDS["Ana"]}))[0] == 401
    assert (await ben.sign_in("Ben"))["role"] == "operator"
    again = await ben.page()
    assert again.latest["hello"]["role"] == "operator"
    for page in (again, pages["Max"]):
        await page.close()
