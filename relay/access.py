"""Who may connect, and as what: the operator token, viewers, the Origin check, and failed-attempt limits.

The way Jupyter does it: an operator token, generated at start-up unless given, travels in the page URL's
fragment (never sent to the server by the browser) and from there in the WebSocket URL (``/ws?token=...``).
Without a valid token a client connects as a ``viewer`` when viewers are allowed, and is refused otherwise.
A handshake whose ``Origin`` is neither the relay's own nor allow-listed is refused even with a valid token
(a page on another site must not drive robots through the operator's browser); a handshake without
``Origin`` (command-line tools) needs the token like any other. Tokens compare in constant time.

Guessing is slowed, never answered with a lock-out: the right token always gets in at once (a stale tab or a
hostile page spraying wrong tokens from the same address must not lock the real operator out, as a per-address
ban did). Each wrong token from an address, past the first few in a window, waits longer for its answer,
doubling up to :data:`MAX_DELAY`: a guesser gets a handful of tries a minute instead of thousands.
"""

from __future__ import annotations

import hmac
import ipaddress
from collections import deque
from dataclasses import dataclass, field

from .protocol import Role

#: Wrong tokens an address may present within the window before its answers are slowed.
FREE_FAILURES = 3
#: The first slowed answer waits this long (s); each further one twice as long, up to MAX_DELAY.
FIRST_DELAY = 0.1
MAX_DELAY = 2.0


class Refused(Exception):
    """The handshake is refused with HTTP ``status`` and a reason a person can act on, after ``delay`` seconds."""

    def __init__(self, status: int, reason: str, delay: float = 0.0) -> None:
        super().__init__(reason)
        self.status = status
        self.reason = reason
        self.delay = delay


@dataclass
class Access:
    token: str | None  # None: no token needed (library use and tests); the command line always sets one
    allow_viewers: bool = False
    allowed_origins: tuple[str, ...] = ()
    window: float = 60.0  # wrong tokens older than this (s) no longer slow an address
    #: Names the Host header may carry besides IP addresses (lower case): see ``check_host``.
    allowed_hosts: frozenset[str] = frozenset({"localhost"})
    _failures: dict[str, deque[float]] = field(default_factory=dict)

    def check_host(self, host: str | None) -> None:
        """DNS rebinding: a hostile page at ``evil.example``, its name re-pointed at 127.0.0.1, sends ``Host`` and
        ``Origin`` both ``evil.example:P``, which pass the Origin check. So the Host must be an IP address or a
        name this relay is known by (localhost, this machine's names, ``--allow-host``). No Host (HTTP/1.0
        tools) is allowed: browsers always send one."""
        if host is None:
            return
        name = host.strip().lower()
        if name.startswith("["):  # [v6]:port
            name = name[1 : name.find("]")] if "]" in name else name
        elif name.count(":") == 1:
            name = name.split(":", 1)[0]
        name = name.rstrip(".")
        try:
            ipaddress.ip_address(name)
            return
        except ValueError:
            pass
        if name in self.allowed_hosts:
            return
        shown = host if len(host) <= 80 else host[:80] + "..."
        raise Refused(
            403,
            f"Host {shown!r} is not a name of this relay (a DNS rebinding attempt?); if you reach the relay by "
            f"that name, start it with --allow-host {name[:80]}",
        )

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

    def admit(self, presented: str | None, address: str, now: float) -> tuple[Role, float]:
        """The role of a handshake presenting ``presented`` from ``address`` and how long (s) to wait before
        answering it; or Refused (with its own delay)."""
        if self.token is None:
            return "operator", 0.0
        if presented is not None and hmac.compare_digest(presented.encode(), self.token.encode()):
            return "operator", 0.0  # whatever wrong tokens came from this address before
        delay = 0.0
        if presented is not None:
            delay = self._failed(address, now)
        if self.allow_viewers:
            return "viewer", delay
        if presented is None:
            raise Refused(401, "an operator token is required: open the URL the relay printed (it ends in #token=...)")
        raise Refused(401, "wrong operator token", delay)

    def _failed(self, address: str, now: float) -> float:
        """Count a wrong token; the delay its answer waits."""
        failures = self._failures.setdefault(address, deque())
        while failures and now - failures[0] > self.window:
            failures.popleft()
        failures.append(now)
        if len(self._failures) > 10_000:
            # Bounded memory under a spray of addresses: forget the oldest entries.
            for key in list(self._failures)[:5_000]:
                del self._failures[key]
        extra = len(failures) - FREE_FAILURES
        return 0.0 if extra <= 0 else min(MAX_DELAY, FIRST_DELAY * 2.0 ** (extra - 1))
