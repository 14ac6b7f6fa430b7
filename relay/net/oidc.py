"""Signing in with the site's OpenID Connect provider (issue #31), beside the relay's own accounts: the authorization
code flow with PKCE, the relay a confidential client.

- ``GET /oidc/login``: a new sign-in: a random ``state``, ``nonce`` and PKCE verifier kept (at most
  :data:`MAX_PENDING`, for :data:`PENDING_LIFETIME`), then a redirect to the provider's authorization endpoint (from its
  discovery document, ``ISSUER/.well-known/openid-configuration``).
- ``GET /oidc/callback``: the provider sends the browser back with a code; the relay exchanges it at the token
  endpoint (with its secret and the verifier) and checks the ID token: its signature against the provider's keys
  (JWKS; RS256 or ES256), issuer, audience, expiry and the nonce of this sign-in (PyJWT). The person's name is the
  token's ``preferred_username`` (else ``email``, else ``sub``), their role the highest station role named in the claim
  :attr:`OidcSettings.role_claim` (a string or a list: ``admin``, ``operator``, ``inspector``, ``viewer``). Nobody
  without one signs in. Then a session opens as with a password (relay/net/sign_in.py) and the browser goes to ``/``.

Every answer from the provider is bounded (:data:`MAX_ANSWER` bytes, :data:`TIMEOUT` s); a failure says what failed,
never a token. The provider is asked through one HTTP client session, its connections kept alive (a sign-in asks up
to three times), made at the first question and closed with the relay (:meth:`OidcSignIn.closing`, a cleanup context).
The client secret comes from ``$XR_RELAY_OIDC_SECRET``, never the command line (other users of the machine can read a
process's arguments).
"""

from __future__ import annotations

import base64
import hashlib
import json
import logging
import secrets
import time
from collections import OrderedDict
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import Any, Final
from urllib.parse import urlencode

import aiohttp
import jwt
from aiohttp import web

from ..accounts.roles import ROLES
from ..wire.messages import Role
from .sign_in import SignIn

logger = logging.getLogger(__name__)

MAX_PENDING: Final = 256
PENDING_LIFETIME: Final = 600.0
MAX_ANSWER: Final = 256 * 1024
TIMEOUT: Final = 10.0
#: How long the provider's discovery document and keys are kept before being asked again.
CACHE: Final = 3600.0
ALGORITHMS: Final = ["RS256", "ES256"]


@dataclass(frozen=True, slots=True)
class OidcSettings:
    issuer: str
    client_id: str
    client_secret: str
    #: The ID token claim that names the person's station role(s).
    role_claim: str = "roles"


class OidcError(Exception):
    """A sign-in the provider or its token did not allow; the message says what, for the person signing in."""


@dataclass(frozen=True, slots=True)
class _Pending:
    nonce: str
    verifier: str
    redirect: str
    created: float


class OidcSignIn:
    def __init__(self, settings: OidcSettings, sign_in: SignIn, clock: Callable[[], float] = time.monotonic) -> None:
        self.settings = settings
        self._sign_in = sign_in
        self._clock = clock
        self._pending: OrderedDict[str, _Pending] = OrderedDict()
        self._discovery: tuple[float, dict[str, Any]] | None = None
        self._keys: tuple[float, jwt.PyJWKSet] | None = None
        #: Made at the first question to the provider (a session belongs to a running event loop), closed by closing.
        self._http: aiohttp.ClientSession | None = None

    async def closing(self, app: web.Application) -> AsyncIterator[None]:
        """cleanup_ctx: the HTTP client session to the provider, closed with the relay."""
        yield
        if self._http is not None:
            await self._http.close()
            self._http = None

    # -- routes -----------------------------------------------------------------------------------

    async def login(self, request: web.Request) -> web.Response:
        try:
            endpoint = str((await self._document())["authorization_endpoint"])
        except (OidcError, KeyError) as exc:
            return _refused(502, f"the sign-in provider cannot be reached: {exc}")
        state, nonce, verifier = (secrets.token_urlsafe(32) for _ in range(3))
        redirect = f"{request.scheme}://{request.host}/oidc/callback"
        self._forget_old()
        self._pending[state] = _Pending(nonce, verifier, redirect, self._clock())
        while len(self._pending) > MAX_PENDING:
            self._pending.popitem(last=False)
        query = {
            "response_type": "code",
            "client_id": self.settings.client_id,
            "redirect_uri": redirect,
            "scope": "openid profile email",
            "state": state,
            "nonce": nonce,
            "code_challenge": _challenge(verifier),
            "code_challenge_method": "S256",
        }
        raise web.HTTPFound(f"{endpoint}?{urlencode(query)}")

    async def callback(self, request: web.Request) -> web.Response:
        self._forget_old()
        pending = self._pending.pop(request.query.get("state", ""), None)
        if pending is None:
            return _refused(400, "this sign-in expired or was not started here: sign in again")
        if "error" in request.query:
            return _refused(403, f"the provider refused: {request.query['error'][:80]}")
        try:
            user, role = await self._signed_in(request.query.get("code", ""), pending)
        except OidcError as exc:
            logger.warning("OpenID Connect sign-in from %s refused: %s", request.remote, exc)
            return _refused(403, str(exc))
        session = self._sign_in.sessions.open(user, role, self._clock(), provider="oidc")
        logger.info("%s signed in as %s with %s from %s", user, role, self.settings.issuer, request.remote)
        response = web.HTTPFound("/")
        self._sign_in.set_cookie(response, session)
        raise response

    # -- the provider -----------------------------------------------------------------------------

    async def _signed_in(self, code: str, pending: _Pending) -> tuple[str, Role]:
        document = await self._document()
        answer = await self._json(
            "the token endpoint",
            "POST",
            str(document["token_endpoint"]),
            data={
                "grant_type": "authorization_code",
                "code": code[:2048],
                "redirect_uri": pending.redirect,
                "client_id": self.settings.client_id,
                "client_secret": self.settings.client_secret,
                "code_verifier": pending.verifier,
            },
        )
        token = answer.get("id_token")
        if not isinstance(token, str):
            raise OidcError("the token endpoint answered without an ID token")
        claims = await self._claims(token, document)
        if not secrets.compare_digest(str(claims.get("nonce", "")), pending.nonce):
            raise OidcError("the ID token is not for this sign-in (nonce)")
        return _name(claims), self._role(claims)

    async def _claims(self, token: str, document: dict[str, Any]) -> dict[str, Any]:
        try:
            kid = jwt.get_unverified_header(token).get("kid")
        except jwt.PyJWTError as exc:
            raise OidcError(f"the ID token is malformed ({type(exc).__name__})") from None
        key = await self._key(kid, str(document["jwks_uri"]))
        try:
            claims: dict[str, Any] = jwt.decode(
                token, key.key, algorithms=ALGORITHMS, audience=self.settings.client_id, issuer=self.settings.issuer,
                options={"require": ["exp", "iat", "iss", "aud", "sub"]}, leeway=30,
            )  # fmt: skip
        except jwt.PyJWTError as exc:
            raise OidcError(f"the ID token does not check: {exc}") from None
        return claims

    async def _key(self, kid: object, uri: str) -> jwt.PyJWK:
        now = self._clock()
        for fresh in (False, True):  # a key not known yet: the provider may have rotated them
            if fresh or self._keys is None or now - self._keys[0] > CACHE:
                try:
                    self._keys = (now, jwt.PyJWKSet.from_dict(await self._json("the provider's keys", "GET", uri)))
                except jwt.PyJWTError as exc:
                    raise OidcError(f"the provider's keys cannot be read: {exc}") from None
            for key in self._keys[1].keys:
                if kid is None or key.key_id == kid:
                    return key
        raise OidcError("the ID token is signed with a key the provider does not publish")

    async def _document(self) -> dict[str, Any]:
        now = self._clock()
        if self._discovery is None or now - self._discovery[0] > CACHE:
            url = self.settings.issuer.rstrip("/") + "/.well-known/openid-configuration"
            document = await self._json("the provider's discovery document", "GET", url)
            for field in ("authorization_endpoint", "token_endpoint", "jwks_uri"):
                if not isinstance(document.get(field), str):
                    raise OidcError(f"the provider's discovery document has no {field}")
            self._discovery = (now, document)
        return self._discovery[1]

    async def _json(self, what: str, method: str, url: str, **kwargs: Any) -> dict[str, Any]:
        """One request to the provider: its JSON object, or OidcError naming ``what`` failed."""
        if self._http is None or self._http.closed:
            self._http = aiohttp.ClientSession(timeout=aiohttp.ClientTimeout(total=TIMEOUT))
        try:
            async with self._http.request(method, url, **kwargs) as response:
                body = await response.content.read(MAX_ANSWER + 1)
                if len(body) > MAX_ANSWER:
                    raise OidcError(f"{what} answered more than {MAX_ANSWER // 1024} KiB")
                if response.status != 200:
                    raise OidcError(f"{what} answered HTTP {response.status}")
        except (TimeoutError, aiohttp.ClientError) as exc:
            raise OidcError(f"{what} cannot be reached ({type(exc).__name__})") from None
        try:
            answer = json.loads(body)
        except ValueError:
            raise OidcError(f"{what} did not answer JSON") from None
        if not isinstance(answer, dict):
            raise OidcError(f"{what} did not answer a JSON object")
        return answer

    def _role(self, claims: dict[str, Any]) -> Role:
        named = claims.get(self.settings.role_claim)
        values = {named} if isinstance(named, str) else set(named) if isinstance(named, list) else set()
        for role in ROLES:  # highest first: admin, operator, inspector, viewer
            if role in values:
                return role
        raise OidcError(
            f"your account has no role at this station: the claim {self.settings.role_claim!r} names none of "
            + ", ".join(ROLES)
        )

    def _forget_old(self) -> None:
        now = self._clock()
        while self._pending and now - next(iter(self._pending.values())).created > PENDING_LIFETIME:
            self._pending.popitem(last=False)


def _name(claims: dict[str, Any]) -> str:
    for field in ("preferred_username", "email", "sub"):
        value = claims.get(field)
        if isinstance(value, str) and value.strip():
            return "".join(c for c in value.strip() if c.isprintable())[:64]
    raise OidcError("the ID token names nobody")


def _challenge(verifier: str) -> str:
    return base64.urlsafe_b64encode(hashlib.sha256(verifier.encode()).digest()).rstrip(b"=").decode()


def _refused(status: int, text: str) -> web.Response:
    return web.Response(status=status, text=f"sign-in refused: {text}\n")


def add_routes(app: web.Application, oidc: OidcSignIn) -> None:
    app.router.add_get("/oidc/login", oidc.login)
    app.router.add_get("/oidc/callback", oidc.callback)
