"""Signing in to the relay with an account (relay/accounts): the routes, the session cookie and the CSRF check.

- ``POST /signin`` ``{"user": ..., "password": ...}``: the password is checked off the event loop (Argon2id takes
  tens of milliseconds and 64 MiB), :data:`CHECKS_AT_ONCE` at a time and at most :data:`WAITING` waiting (more get
  503: a flood of sign-ins cannot hold the relay's memory). A wrong user name and a wrong password get the same
  answer after the same work, slowed per address as wrong tokens are (relay/net/access.py, one count per address).
  Success sets the session cookie (HttpOnly, SameSite=Strict, Secure over TLS) and answers the user, the role and
  the CSRF token.
- ``GET /whoami``: whether the relay has accounts, and the signed-in user, role and CSRF token (a page reloaded keeps
  its cookie, not its token); ``user`` null when signed out.
- ``POST /signout``, ``POST /pair`` (a pairing code for a headset): need the cookie and the ``X-CSRF-Token`` header.
- ``POST /pair/claim`` ``{"code": ...}``: the headset's page takes a session of the same person; wrong codes slowed.

Every POST passes the Origin check of the WebSocket handshake. The handshake itself takes the cookie
(relay/net/server.py): a signed-in page connects as its user, with their role and their name.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import logging
import time
from collections.abc import AsyncIterator, Callable
from typing import Any, Final

from aiohttp import web

from ..accounts.passwords import verify
from ..accounts.sessions import CODE_LIFETIME, LIFETIME, Session, Sessions
from ..accounts.users import UserBook
from .access import Access, Refused
from .account_watch import AccountWatch

logger = logging.getLogger(__name__)

COOKIE: Final = "xr_session"
CSRF_HEADER: Final = "X-CSRF-Token"
CHECKS_AT_ONCE: Final = 2
WAITING: Final = 16
MAX_BODY: Final = 4096
WRONG: Final = "wrong user name or password"


class SignIn:
    """The accounts of one relay: ``book`` (None: no accounts, every route answers 404) and its sessions."""

    def __init__(
        self, book: UserBook | None, access: Access, *, secure: bool, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.book = book
        self.sessions = Sessions()
        #: Removals and role changes made while the relay runs end their sessions and pages (None: no accounts).
        self.watch = AccountWatch(book, self.sessions) if book is not None else None
        #: The site's OpenID Connect provider, when people may also sign in with it (relay/net/oidc.py).
        self.oidc_issuer: str | None = None
        self._access = access
        self._secure = secure
        self._clock = clock
        self._checks = asyncio.Semaphore(CHECKS_AT_ONCE)
        self._waiting = 0

    async def watching(self, app: web.Application) -> AsyncIterator[None]:
        """cleanup_ctx: the users file watched while the relay serves."""
        task = asyncio.create_task(self.watch.run(), name="account watch") if self.watch else None
        yield
        if task is not None:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)

    def session_of(self, request: web.Request) -> Session | None:
        if self.book is None:
            return None
        return self.sessions.get(request.cookies.get(COOKIE), self._clock())

    # -- routes -----------------------------------------------------------------------------------

    async def sign_in(self, request: web.Request) -> web.Response:
        body = await self._body(request)
        user, password = body.get("user"), body.get("password")
        if not isinstance(user, str) or not isinstance(password, str):
            return _text(400, "send JSON with the strings user and password")
        found = await self._checked(user, password)
        if found is None:
            return await self._wrong(request, WRONG)
        name, role = found
        session = self.sessions.open(name, role, self._clock())
        logger.info("%s signed in as %s from %s", name, role, request.remote)
        return self._with_cookie(session, {"user": name, "role": role, "csrf": session.csrf})

    async def whoami(self, request: web.Request) -> web.Response:
        """Always 200, so that a page's every start logs no error: whether the relay has accounts, and who this is."""
        if self.book is None:
            return web.json_response({"accounts": False})
        session = self.session_of(request)
        if session is None:
            return web.json_response({"accounts": True, "user": None, "oidc": self.oidc_issuer})
        return web.json_response({"accounts": True, "user": session.user, "role": session.role, "csrf": session.csrf})

    async def sign_out(self, request: web.Request) -> web.Response:
        session = self._posted(request)
        self.sessions.close(session.id)
        logger.info("%s signed out", session.user)
        response = web.json_response({"signed_out": session.user})
        response.del_cookie(COOKIE, path="/")
        return response

    async def pair(self, request: web.Request) -> web.Response:
        session = self._posted(request)
        code = self.sessions.pairing_code(session, self._clock())
        return web.json_response({"code": code, "expires_in": CODE_LIFETIME})

    async def claim(self, request: web.Request) -> web.Response:
        body = await self._body(request)
        code = body.get("code")
        session = self.sessions.claim(code, self._clock()) if isinstance(code, str) and len(code) < 32 else None
        if session is None:
            return await self._wrong(request, "no such pairing code, or it expired: ask the desktop for a new one")
        logger.info("%s paired a headset from %s", session.user, request.remote)
        return self._with_cookie(session, {"user": session.user, "role": session.role, "csrf": session.csrf})

    # -- parts ------------------------------------------------------------------------------------

    def _known(self) -> None:
        if self.book is None:
            raise web.HTTPNotFound(text="this relay has no accounts (xr-relay users add makes one)\n")

    async def _body(self, request: web.Request) -> dict[str, Any]:
        self._known()
        self._check_origin(request)
        raw = await request.content.read(MAX_BODY + 1)
        if len(raw) > MAX_BODY:
            raise web.HTTPRequestEntityTooLarge(max_size=MAX_BODY, actual_size=len(raw))
        try:
            body = json.loads(raw or b"{}")
        except ValueError:
            raise web.HTTPBadRequest(text="the body is not JSON\n") from None
        if not isinstance(body, dict):
            raise web.HTTPBadRequest(text="the body is not a JSON object\n")
        return body

    def _check_origin(self, request: web.Request) -> None:
        try:
            self._access.check_origin(request.headers.get("Origin"), f"{request.scheme}://{request.host}")
        except Refused as exc:
            raise web.HTTPForbidden(text=exc.reason + "\n") from None

    def _posted(self, request: web.Request) -> Session:
        """The session of a state-changing request: the cookie, and the CSRF token in its header."""
        self._known()
        self._check_origin(request)
        session = self.session_of(request)
        if session is None:
            raise web.HTTPUnauthorized(text="not signed in\n")
        if not hmac.compare_digest(request.headers.get(CSRF_HEADER, "").encode(), session.csrf.encode()):
            raise web.HTTPForbidden(text=f"missing or wrong {CSRF_HEADER} header\n")
        return session

    async def _checked(self, user: str, password: str) -> tuple[str, Any] | None:
        """(name, role) when the password is the user's; the check off the loop, a few at a time."""
        assert self.book is not None
        if self._waiting >= WAITING:
            raise web.HTTPServiceUnavailable(text="too many sign-ins at once: try again in a moment\n")
        self._waiting += 1
        try:
            async with self._checks:
                return await asyncio.to_thread(_check, self.book, user[:64], password)
        finally:
            self._waiting -= 1

    async def _wrong(self, request: web.Request, text: str) -> web.Response:
        delay = self._access.slow(request.remote or "unknown", self._clock())
        await asyncio.sleep(delay)
        return _text(401, text)

    def _with_cookie(self, session: Session, body: dict[str, Any]) -> web.Response:
        response = web.json_response(body)
        self.set_cookie(response, session)
        return response

    def set_cookie(self, response: web.StreamResponse, session: Session) -> None:
        """The session's cookie on a response (also the OpenID Connect sign-in's redirect: relay/net/oidc.py)."""
        response.set_cookie(
            COOKIE, session.id, max_age=int(LIFETIME), path="/", httponly=True, samesite="Strict", secure=self._secure
        )


def _check(book: UserBook, user: str, password: str) -> tuple[str, Any] | None:
    """Worker thread: the user's name and role when the password matches (an unknown user costs the same)."""
    found = book.hash_of(user)
    ok = verify(found[1] if found else None, password)
    return (found[0].name, found[0].role) if ok and found else None


def _text(status: int, text: str) -> web.Response:
    return web.Response(status=status, text=text + "\n")


def add_routes(app: web.Application, sign_in: SignIn) -> None:
    app.router.add_post("/signin", sign_in.sign_in)
    app.router.add_post("/signout", sign_in.sign_out)
    app.router.add_get("/whoami", sign_in.whoami)
    app.router.add_post("/pair", sign_in.pair)
    app.router.add_post("/pair/claim", sign_in.claim)
