"""A loopback OpenID Connect provider for the tests: the discovery document, an authorization endpoint that signs
one person in at once (no login page: ``Provider.person`` is who), the token endpoint (the client secret, the code
and its PKCE verifier checked) and its keys (RS256). ``Provider.forge`` makes its next ID token wrong on purpose."""

from __future__ import annotations

import asyncio
import base64
import hashlib
import secrets
import time
from collections.abc import Awaitable, Callable
from typing import Any
from urllib.parse import urlencode

import jwt
from aiohttp import web
from cryptography.hazmat.primitives.asymmetric import rsa

CLIENT_ID = "xr-relay"
SECRET = "a-client-secret-" + "x" * 16


class Provider:
    def __init__(self) -> None:
        self.key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        self.kid = "key-1"
        #: The claims of whoever signs in next (beside iss, aud, sub, exp, iat and the nonce).
        self.person: dict[str, Any] = {"sub": "u-1", "preferred_username": "ana@site.example", "roles": ["operator"]}
        #: "key": sign with another key under the same kid; "audience": for another client; None: a good token.
        self.forge: str | None = None
        self.codes: dict[str, tuple[str, str, str]] = {}
        self.tokens_issued = 0
        #: The connections the relay asked over (discovery, token, keys; not the browser's /authorize).
        self.relay_connections: set[asyncio.BaseTransport] = set()
        self.runner: web.AppRunner | None = None
        self.issuer = ""

    async def start(self) -> Provider:
        app = web.Application(middlewares=[self._seen])
        app.router.add_get("/.well-known/openid-configuration", self._discovery)
        app.router.add_get("/authorize", self._authorize)
        app.router.add_post("/token", self._token)
        app.router.add_get("/jwks", self._jwks)
        self.runner = web.AppRunner(app, access_log=None)
        await self.runner.setup()
        site = web.TCPSite(self.runner, "127.0.0.1", 0)
        await site.start()
        port = self.runner.addresses[0][1]
        self.issuer = f"http://127.0.0.1:{port}"
        return self

    async def close(self) -> None:
        if self.runner is not None:
            await self.runner.cleanup()

    @web.middleware
    async def _seen(
        self, request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
    ) -> web.StreamResponse:
        if request.path != "/authorize" and request.transport is not None:
            self.relay_connections.add(request.transport)
        return await handler(request)

    async def _discovery(self, request: web.Request) -> web.Response:
        return web.json_response({
            "issuer": self.issuer,
            "authorization_endpoint": f"{self.issuer}/authorize",
            "token_endpoint": f"{self.issuer}/token",
            "jwks_uri": f"{self.issuer}/jwks",
        })  # fmt: skip

    async def _authorize(self, request: web.Request) -> web.Response:
        q = request.query
        assert q["response_type"] == "code" and q["client_id"] == CLIENT_ID and q["code_challenge_method"] == "S256"
        assert "openid" in q["scope"].split()
        code = secrets.token_urlsafe(16)
        self.codes[code] = (q["nonce"], q["code_challenge"], q["redirect_uri"])
        raise web.HTTPFound(f"{q['redirect_uri']}?{urlencode({'code': code, 'state': q['state']})}")

    async def _token(self, request: web.Request) -> web.Response:
        form = await request.post()
        if form.get("client_id") != CLIENT_ID or form.get("client_secret") != SECRET:
            return web.json_response({"error": "invalid_client"}, status=401)
        found = self.codes.pop(str(form.get("code")), None)
        verifier = str(form.get("code_verifier", ""))
        challenge = base64.urlsafe_b64encode(hashlib.sha256(verifier.encode()).digest()).rstrip(b"=").decode()
        if found is None or found[1] != challenge or found[2] != form.get("redirect_uri"):
            return web.json_response({"error": "invalid_grant"}, status=400)
        now = int(time.time())
        claims = {"iss": self.issuer, "aud": CLIENT_ID, "iat": now, "exp": now + 300, "nonce": found[0], **self.person}
        key: Any = self.key
        if self.forge == "key":
            key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        elif self.forge == "audience":
            claims["aud"] = "another-client"
        self.tokens_issued += 1
        token = jwt.encode(claims, key, algorithm="RS256", headers={"kid": self.kid})
        return web.json_response({"id_token": token, "access_token": "unused", "token_type": "Bearer"})

    async def _jwks(self, request: web.Request) -> web.Response:
        jwk = jwt.algorithms.RSAAlgorithm.to_jwk(self.key.public_key(), as_dict=True)
        return web.json_response({"keys": [{**jwk, "kid": self.kid, "use": "sig", "alg": "RS256"}]})
