"""Accounts in the page (issue #31): a relay with a users file asks people to sign in, in the page, and then knows
them: Ana's E-STOP reads "by Ana" on Ben's page, Ben (a viewer) has nothing to press until the admin makes him an
operator (his page asks him to sign in again, and his reset names Ana's E-STOP), and a headset's page signs in as Ana
with the code her desktop shows, without her password."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path

from playwright.async_api import Browser

from relay.accounts.users import UserBook
from relay.cli.options import Options
from relay.config import load_config
from tests.conftest import ROOT, RunningRelay, start_relay
from tests.helpers.browser import SOFTWARE_GL, Client, confirm_reset, fixture
from tests.helpers.oidc import CLIENT_ID, SECRET, Provider

PASSWORDS = {"Ana": "ana-correct-horse", "Ben": "ben-battery-staple"}


@fixture
async def site(tmp_path: Path) -> AsyncIterator[RunningRelay]:
    book = UserBook(tmp_path / "users.sqlite")
    await asyncio.to_thread(book.add, "Ana", "operator", PASSWORDS["Ana"])
    await asyncio.to_thread(book.add, "Ben", "viewer", PASSWORDS["Ben"])
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    running = await start_relay(config, options=Options(users=str(book.path), database=str(tmp_path / "i.sqlite")))
    try:
        yield running
    finally:
        await running.runner.cleanup()


async def signed_in(browser: Browser, url: str, name: str, user: str | None, code: str | None = None) -> Client:
    """A page of the station that signs in through its dialog: as ``user`` with their password, or by ``code``."""
    page = await browser.new_page(viewport={"width": 1280, "height": 760})
    client = Client(page, name)
    await page.goto(url)
    dialog = page.locator("#sign-in-dialog")
    await dialog.wait_for(state="visible", timeout=30_000)
    if user is not None:
        await dialog.locator('input[name="user"]').fill(user.lower())  # the account's own spelling comes back
        await dialog.locator('input[name="password"]').fill("not-the-password")
        await dialog.locator('button[value="sign-in"]').click()
        await page.locator("#sign-in-dialog .error", has_text="wrong user name or password").wait_for(timeout=20_000)
        await dialog.locator('input[name="password"]').fill(PASSWORDS[user])
        await client.shot("sign-in", "sign-in.png")
        await dialog.locator('button[value="sign-in"]').click()
    else:
        assert code is not None
        await dialog.locator('input[name="code"]').fill(code)
        await dialog.locator('button[value="pair"]').click()
    await client.wait("s.connected && Object.keys(s.robots).length > 0", 30)
    await dialog.wait_for(state="hidden", timeout=5_000)
    return client


async def test_people_sign_in_in_the_page_and_are_named_by_their_accounts(
    site: RunningRelay, browser: Browser, tmp_path: Path
) -> None:
    ana = await signed_in(browser, f"{site.url}/?{SOFTWARE_GL}", "ana", "Ana")
    ben = await signed_in(browser, f"{site.url}/?{SOFTWARE_GL}", "ben", "Ben")
    assert await ana.page.locator("#account .who").inner_text() == "Ana (operator)"
    assert await ben.page.locator("#account .who").inner_text() == "Ben (viewer)"
    assert not await ana.page.locator("#name-dialog").is_visible()  # the account names her: nothing to ask
    await ana.page.locator("#viewport canvas").focus()
    await ana.page.keyboard.press("Space")  # E-STOP
    s = await ben.wait("s.estop.page && s.estop", 10)
    assert s["banner"] == "ALL ROBOTS E-STOPPED · by Ana", s
    # Ben watches: his banner has no reset, and the relay would refuse one (tests/test_accounts.py).
    assert not await ben.page.locator('#estop-banner button[data-button="estop:reset"]').is_visible()

    # The admin makes Ben an operator while he watches: his page is signed out (its account changed) and asks him to
    # sign in again; then he may reset, and the reset first says whose E-STOP it lifts.
    await asyncio.to_thread(UserBook(tmp_path / "users.sqlite").set_role, "Ben", "operator")
    dialog = ben.page.locator("#sign-in-dialog")
    await dialog.wait_for(state="visible", timeout=30_000)
    await dialog.locator('input[name="user"]').fill("Ben")
    await dialog.locator('input[name="password"]').fill(PASSWORDS["Ben"])
    await dialog.locator('button[value="sign-in"]').click()
    await ben.page.locator("#account .who", has_text="Ben (operator)").wait_for(timeout=30_000)
    await ben.wait("s.connected && s.estop.page", 30)
    question = await confirm_reset(ben.page)
    assert question.startswith("Reset the E-STOP pressed by Ana on all robots?"), question
    await ana.wait("!s.estop.page", 10)

    # Ana pairs a headset: its page signs in by the code alone, as her.
    await ana.page.locator('#account button[data-account="pair"]').click()
    code_box = ana.page.locator("#pair-dialog .code")
    await code_box.wait_for(state="visible", timeout=10_000)
    code = (await code_box.inner_text()).strip()
    assert len(code) == 6, code
    headset = await signed_in(browser, f"{site.url}/?{SOFTWARE_GL}", "headset", None, code=code.lower())
    assert await headset.page.locator("#account .who").inner_text() == "Ana (operator)"
    # The 401s of /whoami, /auth and the wrong password are the page asking, not failing.
    errors = [e for c in (ana, ben, headset) for e in c.errors if "status of 401" not in e]
    assert errors == [], errors
    for client in (ana, ben, headset):
        await client.page.close()


async def test_a_person_signs_in_with_the_sites_provider_from_the_page(browser: Browser, tmp_path: Path) -> None:
    """The sign-in dialog offers the site's OpenID Connect provider (a loopback one, tests/helpers/oidc.py); its link
    goes there and back, and the page comes back signed in as the person the provider named, with their role."""
    provider = await Provider().start()
    book = UserBook(tmp_path / "users.sqlite")
    await asyncio.to_thread(book.add, "Root", "admin", "root-admin-pw")
    config = await asyncio.to_thread(load_config, ROOT / "robots.yaml")
    options = Options(
        users=str(book.path), database=str(tmp_path / "i.sqlite"), oidc_issuer=provider.issuer,
        oidc_client_id=CLIENT_ID, oidc_secret=SECRET,
    )  # fmt: skip
    site = await start_relay(config, options=options)
    page = await browser.new_page(viewport={"width": 1280, "height": 760})
    client = Client(page, "oidc")
    try:
        await page.goto(site.url)
        link = page.locator("#sign-in-dialog a.oidc")
        await link.wait_for(state="visible", timeout=30_000)
        assert await link.inner_text() == f"Sign in with {provider.issuer.removeprefix('http://')}"
        await client.shot("01-provider-offered")
        await link.click()
        await page.locator("#account .who", has_text="ana@site.example (operator)").wait_for(timeout=30_000)
        await client.wait("s.connected && Object.keys(s.robots).length > 0", 30)
        assert not await page.locator("#sign-in-dialog").is_visible()
        assert [e for e in client.errors if "status of 401" not in e] == []
    finally:
        await page.close()
        await site.runner.cleanup()
        await provider.close()
