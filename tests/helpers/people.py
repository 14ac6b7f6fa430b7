"""A person's browser against a relay with accounts: its cookie jar, signing in with a password, and the pages
(WebSocket clients) its session opens."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import aiohttp
import orjson
from yarl import URL

from relay.net.sign_in import COOKIE, CSRF_HEADER
from tests.conftest import RunningRelay
from tests.wsclient import TestClient


class Person:
    """A browser of one person: its cookie jar and, once signed in, the CSRF token its page read."""

    def __init__(self, relay: RunningRelay, passwords: Mapping[str, str] | None = None) -> None:
        self.relay = relay
        self.passwords = passwords or {}
        self.http = aiohttp.ClientSession(cookie_jar=aiohttp.CookieJar(unsafe=True))  # unsafe: 127.0.0.1 cookies
        self.csrf = ""

    async def post(self, path: str, body: dict[str, Any] | None = None, *, csrf: bool = True) -> tuple[int, Any]:
        headers = {"Origin": self.relay.url}
        if csrf and self.csrf:
            headers[CSRF_HEADER] = self.csrf
        async with self.http.post(self.relay.url + path, data=orjson.dumps(body or {}), headers=headers) as response:
            text = await response.text()
            return response.status, (orjson.loads(text) if response.content_type == "application/json" else text)

    async def sign_in(self, user: str, password: str | None = None) -> dict[str, Any]:
        status, body = await self.post("/signin", {"user": user, "password": password or self.passwords[user]})
        assert status == 200, body
        self.csrf = body["csrf"]
        return dict(body)

    async def page(self) -> TestClient:
        cookie = self.http.cookie_jar.filter_cookies(URL(self.relay.url)).get(COOKIE)
        headers = {"Origin": self.relay.url, **({"Cookie": f"{COOKIE}={cookie.value}"} if cookie else {})}
        client = await TestClient.open(self.relay.ws_url, additional_headers=headers)
        await client.hello()
        return client

    async def close(self) -> None:
        await self.http.close()
