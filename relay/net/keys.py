"""The application's typed state keys (aiohttp ``AppKey``): what relay.net.server builds, and its routes read."""

from __future__ import annotations

from aiohttp import web

from ..station.core import Relay
from .access import Access
from .guard import ConnectionGuard
from .sign_in import SignIn

RELAY_KEY = web.AppKey("relay", Relay)
ACCESS_KEY = web.AppKey("access", Access)
SOCKETS_KEY = web.AppKey("sockets", set[web.WebSocketResponse])
GUARD_KEY = web.AppKey("guard", ConnectionGuard)
SIGN_IN_KEY = web.AppKey("sign_in", SignIn)
