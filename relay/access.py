"""Who may connect, and as what: the operator token, viewers, the Origin check, and failed-attempt limits.

The way Jupyter does it: an operator token, generated at start-up unless given, travels in the page URL's
fragment (never sent to the server by the browser) and from there in the WebSocket URL (``/ws?token=...``).
Without a valid token a client connects as a ``viewer`` when viewers are allowed, and is refused otherwise.
A handshake whose ``Origin`` is neither the relay's own nor allow-listed is refused even with a valid token
(a page on another site must not drive robots through the operator's browser); a handshake without
``Origin`` (command-line tools) needs the token like any other. Tokens compare in constant time, and an
address that keeps presenting wrong tokens is refused for a while.
"""

from __future__ import annotations

import hmac
from collections import deque
from dataclasses import dataclass, field

from .protocol import Role


class Refused(Exception):
    """The handshake is refused with HTTP ``status`` and a reason a person can act on."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status
        self.reason = reason


@dataclass
class Access:
    token: str | None  # None: no token needed (library use and tests); the command line always sets one
    allow_viewers: bool = False
    allowed_origins: tuple[str, ...] = ()
    max_failures: int = 10  # wrong tokens per address within `window` before it is refused for a while
    window: float = 60.0
    _failures: dict[str, deque[float]] = field(default_factory=dict)

    def check_origin(self, origin: str | None, own_origin: str) -> None:
        if origin is None:
            return
        if origin.rstrip("/") == own_origin or origin.rstrip("/") in self.allowed_origins:
            return
        raise Refused(
            403,
            f"origin {origin} is not allowed; open the relay's own page, or start the relay with "
            f"--allow-origin {origin}",
        )

    def role(self, presented: str | None, address: str, now: float) -> Role:
        """The role of a handshake presenting ``presented`` from ``address``, or Refused."""
        if self.token is None:
            return "operator"
        failures = self._failures.get(address)
        if failures:
            while failures and now - failures[0] > self.window:
                failures.popleft()
            if len(failures) >= self.max_failures:
                raise Refused(429, "too many wrong tokens from this address; wait a minute")
        if presented is not None and hmac.compare_digest(presented.encode(), self.token.encode()):
            return "operator"
        if presented is not None:
            self._failures.setdefault(address, deque()).append(now)
            if len(self._failures) > 10_000:
                # Bounded memory under a spray of addresses: forget the oldest entries.
                for key in list(self._failures)[:5_000]:
                    del self._failures[key]
        if self.allow_viewers:
            return "viewer"
        if presented is None:
            raise Refused(401, "an operator token is required: open the URL the relay printed (it ends in #token=...)")
        raise Refused(401, "wrong operator token")
