"""The relay's Content-Security-Policy (relay/net/headers.py) against the pages it serves, in Debian's Chromium: the
operator station on the desktop and with the emulated headset, a finding with its capture image in the findings
list, and the HTML report of a mission. Every page loads, connects and draws with no violation reported, and an
injected inline handler is blocked (the policy is enforced, so a violation would be seen)."""

from __future__ import annotations

from playwright.async_api import Browser, Page

from tests.helpers.browser import HEADSET, SOFTWARE_GL, Client, Station
from tests.wsclient import TestClient

#: Collects every violation the page reports (the document's securitypolicyviolation events), from its first script.
WATCH = """
window.__csp = [];
document.addEventListener('securitypolicyviolation', (e) =>
  window.__csp.push(`${e.effectiveDirective} blocked ${e.blockedURI || 'inline'} at ${e.sourceFile}:${e.lineNumber}`));
"""


async def violations(page: Page) -> list[str]:
    found: list[str] = await page.evaluate("window.__csp")
    return found


async def enforced(client: Client, console: list[str]) -> None:
    """The control: markup with an inline handler is blocked and reported, as injected markup would be (its
    console lines are then forgotten)."""
    page = client.page
    assert client.errors == [], client.errors
    inject = "() => document.body.insertAdjacentHTML('beforeend', '<img src=\"data:,\" onerror=\"window.__ran = 1\">')"
    await page.evaluate(inject)
    await page.wait_for_function("() => window.__csp.some((v) => v.startsWith('script-src-attr'))", timeout=10_000)
    assert await page.evaluate("window.__ran") is None
    await page.wait_for_timeout(200)
    console.clear()
    client.errors.clear()


async def test_the_station_and_the_report_pass_the_content_security_policy(station: Station, browser: Browser) -> None:
    """Measured before: no Content-Security-Policy (nor frame-ancestors) on any page (issue 28, finding 7d)."""
    page = await browser.new_page(viewport={"width": 1280, "height": 760})
    await page.add_init_script(WATCH)
    console: list[str] = []
    page.on("console", lambda m: console.append(m.text) if "Content Security Policy" in m.text else None)
    page.on("worker", lambda worker: worker.on("console", lambda m: console.append(f"worker: {m.text}")))
    client = Client(page, "csp")
    try:
        response = await page.goto(f"{station.url}/?name=Tess&{SOFTWARE_GL}")
        assert response is not None
        policy = response.headers.get("content-security-policy", "")
        assert "frame-ancestors 'none'" in policy and "'unsafe-inline'" not in policy, policy
        await client.wait("s.connected && Object.keys(s.robots).length > 0 && s.twin.state === 'loaded'", 60)
        await client.drawn(2)
        # A finding from robot1's live camera (the operator's pixel), shown in the list with its status colour;
        # selected, its capture image loads from /captures.
        operator = await TestClient.open(station.running.ws_url)
        await operator.hello()
        added = await operator.request(
            {"identifier": "target/add", "target": "csp-1", "robot": "robot1", "u": 240, "v": 360}, timeout=30
        )
        assert added["identifier"] == "ack", added
        await page.wait_for_selector("#findings li[data-finding] .dot", timeout=20_000)
        colour = await page.eval_on_selector(
            "#findings li[data-finding] .dot", "(e) => getComputedStyle(e).backgroundColor"
        )
        assert colour == "rgb(232, 163, 23)", colour  # needs_review's, set through CSSOM
        await page.click("#findings li[data-finding]")
        await page.wait_for_function(
            "() => (document.querySelector('#findings .capture img') || {}).naturalWidth > 0", timeout=20_000
        )
        # A mission that inspects the new target: its report, with the finding's status and image.
        started = await operator.request(
            {"identifier": "mission/start", "robot": "robot1", "steps": [{"inspect": "csp-1"}]}, timeout=30
        )
        assert started["identifier"] == "ack", started
        done = await operator.wait_for(lambda m: m["identifier"] == "mission" and m["state"] == "done", 90)
        await operator.close()
        assert await violations(page) == [] and console == [], (await violations(page), console)
        await enforced(client, console)

        # The report of that mission: its embedded stylesheet, status colours and images.
        report = await page.goto(f"{station.url}/report/{done['id'].split('.')[0]}.html")
        assert report is not None and report.ok
        assert await page.eval_on_selector("span.status", "(e) => getComputedStyle(e).backgroundColor") != (
            "rgba(0, 0, 0, 0)"
        )
        assert await page.locator("svg image").count() >= 1
        assert await violations(page) == [] and console == [], (await violations(page), console)
        await enforced(client, console)
        # The page asking for a range (its last seven days to start with), and the report its form asks for.
        await page.goto(f"{station.url}/report/range.html")
        async with page.expect_navigation():
            await page.click("button[formaction='range.html']")
        assert "/report/range.html?from=" in page.url and await page.locator("span.status").count() >= 1, page.url
        assert await violations(page) == [] and console == [], (await violations(page), console)
        await enforced(client, console)

        # The emulated headset (IWER, ?emulate=quest3): the same policy, nothing else needed.
        await page.goto(f"{station.url}/?name=Tess&{HEADSET}&{SOFTWARE_GL}")
        await client.wait("s.connected && s.twin.state === 'loaded' && s.vr.available", 60)
        await page.click("#enter-vr")
        await client.wait("s.presenting", 30)
        await client.frames(3)
        assert await violations(page) == [] and console == [], (await violations(page), console)
        assert client.errors == [], client.errors
    finally:
        await page.close()
