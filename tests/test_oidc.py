"""Signing in with the site's OpenID Connect provider (issue #31; relay/net/oidc.py), against a real provider on
loopback (tests/helpers/oidc.py): the authorization code flow with PKCE through real redirects, the ID token's
signature, audience and nonce checked, the role from its claim; a forged or roleless token, a replayed or unknown
callback and a provider that cannot be reached sign nobody in and say why."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from yarl import URL

from relay.accounts.sessions import Sessions
from relay.accounts.users import UserBook
from relay.cli.main import oidc_refusal
from relay.cli.options import Options
from relay.config import FleetConfig
from relay.net.account_watch import CLOSE_CODE as ACCOUNT_CHANGED
from relay.net.account_watch import PERIOD as WATCH_PERIOD
from relay.net.sign_in import COOKIE
from tests.conftest import LOAD_SLACK, RunningRelay, start_relay
from tests.helpers.oidc import CLIENT_ID, SECRET, Provider
from tests.helpers.people import Person
from tests.helpers.waiting import wait_until
from tests.wsclient import TestClient


@pytest.fixture
async def provider() -> AsyncIterator[Provider]:
    p = await Provider().start()
    try:
        yield p
    finally:
        await p.close()


@pytest.fixture
async def site(fleet_config: FleetConfig, tmp_path: Path, provider: Provider) -> AsyncIterator[RunningRelay]:
    book = UserBook(tmp_path / "users.sqlite")
    await asyncio.to_thread(book.add, "Root", "admin", "root-admin-pw")
    options = Options(
        users=str(book.path), audit_log=str(tmp_path / "audit.jsonl"), database=str(tmp_path / "i.sqlite"),
        oidc_issuer=provider.issuer, oidc_client_id=CLIENT_ID, oidc_secret=SECRET,
    )  # fmt: skip
    running = await start_relay(fleet_config, options=options)
    try:
        yield running
    finally:
        await running.runner.cleanup()


async def sign_in(site: RunningRelay, http: aiohttp.ClientSession) -> tuple[int, str, dict[str, Any]]:
    """A browser's sign-in: /oidc/login, the provider, back; the last status and text, and /whoami after."""
    async with http.get(f"{site.url}/oidc/login") as response:
        status, text = response.status, await response.text()
    async with http.get(f"{site.url}/whoami") as response:
        return status, text, await response.json()


def browser() -> aiohttp.ClientSession:
    return aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True))  # unsafe: cookies of 127.0.0.1


async def test_a_person_signs_in_with_the_provider_and_gets_the_role_its_token_names(
    site: RunningRelay, provider: Provider, tmp_path: Path
) -> None:
    async with browser() as http:
        async with http.get(f"{site.url}/whoami") as response:
            assert (await response.json())["oidc"] == provider.issuer  # the page offers the provider's button
        status, text, who = await sign_in(site, http)
        assert status == 200 and "xr-relay" in text  # back on the station's page
        assert who["user"] == "ana@site.example" and who["role"] == "operator", who
        cookie = http.cookie_jar.filter_cookies(URL(site.url)).get(COOKIE)
        assert cookie is not None
        page = await TestClient.open(
            site.ws_url, additional_headers={"Origin": site.url, "Cookie": f"{COOKIE}={cookie.value}"}
        )
        hello = await page.hello()
        assert hello["role"] == "operator"
        ack = await page.request({"identifier": "estop"})
        assert ack["identifier"] == "ack"
        await page.close()
    # Who did it is the person the provider named, in the audit log too.
    audit = (tmp_path / "audit.jsonl").read_text()
    assert '"user":"ana@site.example"' in audit.replace(" ", ""), audit[-500:]
    # The highest station role among several wins; the users file's changes do not end a provider's session.
    provider.person = {"sub": "u-2", "preferred_username": "ida", "roles": ["viewer", "inspector"]}
    async with browser() as http:
        assert (await sign_in(site, http))[2]["role"] == "inspector"


@pytest.mark.parametrize(
    ("forge", "person", "says"),
    [
        ("key", None, "does not check"),
        ("audience", None, "does not check"),
        (None, {"sub": "u-3", "preferred_username": "eve", "groups": ["operator"]}, "no role at this station"),
    ],
)
async def test_a_forged_or_roleless_token_signs_nobody_in_and_says_why(
    site: RunningRelay, provider: Provider, forge: str | None, person: dict[str, Any] | None, says: str
) -> None:
    provider.forge = forge
    if person is not None:
        provider.person = person
    async with browser() as http:
        status, text, who = await sign_in(site, http)
    assert status == 403 and says in text, (status, text)
    assert who["user"] is None
    assert provider.tokens_issued == 1  # the provider was asked; its answer was refused


async def test_an_unknown_or_replayed_callback_and_an_unreachable_provider_sign_nobody_in(
    fleet_config: FleetConfig, site: RunningRelay, provider: Provider, tmp_path: Path
) -> None:
    async with browser() as http:
        async with http.get(f"{site.url}/oidc/callback?code=x&state=never-started") as response:
            assert response.status == 400 and "sign in again" in await response.text()
        # A callback replayed (a code and state seen in a browser's history): its state was used once.
        async with http.get(f"{site.url}/oidc/login", allow_redirects=False) as response:
            to_provider = response.headers["Location"]
        async with http.get(to_provider, allow_redirects=False) as response:
            back = response.headers["Location"]
        async with http.get(back, allow_redirects=False) as response:
            assert response.status == 302 and response.headers["Location"] == "/"
        async with browser() as thief, thief.get(back, allow_redirects=False) as response:
            assert response.status == 400
    # A provider that cannot be reached: the page is told so, nobody is signed in.
    book = tmp_path / "users.sqlite"
    options = Options(users=str(book), database=str(tmp_path / "j.sqlite"), oidc_issuer="http://127.0.0.1:9",
                      oidc_client_id=CLIENT_ID, oidc_secret=SECRET)  # fmt: skip
    lost = await start_relay(fleet_config, options=options)
    try:
        async with browser() as http, http.get(f"{lost.url}/oidc/login", allow_redirects=False) as response:
            assert response.status == 502 and "cannot be reached" in await response.text()
    finally:
        await lost.runner.cleanup()


async def test_the_relay_asks_the_provider_over_one_session_that_closes_with_the_relay(
    fleet_config: FleetConfig, provider: Provider, tmp_path: Path
) -> None:
    """Two sign-ins ask the provider four times (its discovery document and keys are kept): over one kept-alive
    connection of the relay's one client session, not a session (and a connection) a request as before; the
    session is closed when the relay is, and with it the connection."""
    book = UserBook(tmp_path / "users.sqlite")
    options = Options(users=str(book.path), database=str(tmp_path / "k.sqlite"), oidc_issuer=provider.issuer,
                      oidc_client_id=CLIENT_ID, oidc_secret=SECRET)  # fmt: skip
    relay = await start_relay(fleet_config, options=options)
    try:
        for _ in range(2):
            async with browser() as http:
                assert (await sign_in(relay, http))[2]["user"] == "ana@site.example"
        assert provider.tokens_issued == 2
        assert len(provider.relay_connections) == 1, provider.relay_connections
    finally:
        await relay.runner.cleanup()
    await wait_until(
        lambda: all(c.is_closing() for c in provider.relay_connections), 5.0, "the relay's connection closed"
    )


def test_the_command_line_refuses_a_provider_in_clear_without_a_secret_or_without_accounts() -> None:
    assert oidc_refusal(None, True, "") is None
    assert oidc_refusal("https://id.site.example/realms/plant", True, "s") is None
    assert oidc_refusal("http://127.0.0.1:9000", True, "s") is None  # loopback: a test provider
    assert "https" in str(oidc_refusal("http://id.site.example", True, "s"))
    assert "XR_RELAY_OIDC_SECRET" in str(oidc_refusal("https://id.site.example", True, ""))
    assert "--no-accounts" in str(oidc_refusal("https://id.site.example", False, "s"))


def test_a_change_of_the_users_file_leaves_the_providers_sessions_alone() -> None:
    sessions = Sessions()
    local = sessions.open("ana", "operator", 0.0)
    provided = sessions.open("ana", "operator", 0.0, provider="oidc")
    code = sessions.pairing_code(provided, 0.0)
    headset = sessions.claim(code, 0.5)  # a headset paired to the provider's session is the provider's too
    assert headset is not None and (headset.via, headset.provider) == ("paired", "oidc")
    assert sessions.end_changed({}) == {"ana"}  # ana left the users file
    assert sessions.get(local.id, 1.0) is None and sessions.get(provided.id, 1.0) is not None
    assert sessions.get(headset.id, 1.0) is not None


async def test_a_local_account_removed_closes_its_own_pages_and_not_the_providers_person_of_that_name(
    site: RunningRelay, provider: Provider, tmp_path: Path
) -> None:
    """The users file's Root and the provider's root are two people: Root removed from the file is signed out and
    his page closed; the provider's root, signed in with a page and a paired headset, stays."""
    provider.person = {"sub": "u-9", "preferred_username": "root", "roles": ["operator"]}
    local = Person(site, {"Root": "root-admin-pw"})
    async with browser() as http:
        try:
            who = (await sign_in(site, http))[2]
            assert who["user"] == "root" and who["role"] == "operator", who
            cookie = http.cookie_jar.filter_cookies(URL(site.url)).get(COOKIE)
            assert cookie is not None
            provided = await TestClient.open(
                site.ws_url, additional_headers={"Origin": site.url, "Cookie": f"{COOKIE}={cookie.value}"}
            )
            await provided.hello()
            assert (await local.sign_in("Root"))["role"] == "admin"
            own = await local.page()
            book = UserBook(tmp_path / "users.sqlite")
            await asyncio.to_thread(book.add, "Ops", "admin", "ops-admin-pw")  # Root is not the last admin
            await asyncio.to_thread(book.remove, "Root")
            await wait_until(lambda: own.closed_code is not None, 3 * WATCH_PERIOD + LOAD_SLACK, "Root's page closed")
            assert own.closed_code == ACCOUNT_CHANGED
            await asyncio.sleep(2 * WATCH_PERIOD)  # longer than the watch's look: the other root's page stays
            assert provided.closed_code is None
            seen = len(provided.messages)
            await provided.wait_for(lambda m: m["identifier"].endswith("/pose"), 10, seen)  # still fed
            await provided.close()
        finally:
            await local.close()
