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
doubling up to :data:`MAX_DELAY`, and the answers to one address's wrong tokens come one after another, that far
apart: a guesser gets at most 30 tries a minute however many connections it opens at once (40 parallel guesses
at /report were all answered within 0.02 s when each answer waited on its own). IPv6 addresses count by their
/64, the block one machine is usually given. Every route that takes a token (the WebSocket handshake, ``/auth``,
``/report``, ``/captures``) asks :meth:`Access.admit`, so they share one count per address.

A token is only as good as its entropy: :func:`token_bits` estimates it (conservatively) for the command line,
which refuses a token under :data:`MIN_TOKEN_BITS` (a 4-digit token was found through /report in 3.5 s).
"""

from __future__ import annotations

import hmac
import ipaddress
import math
import string
import zlib
from collections import deque
from dataclasses import dataclass, field

from ..session.protocol import Role

#: Wrong tokens an address may present within the window before its answers are slowed.
FREE_FAILURES = 3
#: The first slowed answer waits this long (s); each further one twice as long, up to MAX_DELAY.
FIRST_DELAY = 0.1
MAX_DELAY = 2.0
#: Entropy (bits) the command line asks of an operator token: out of reach of any guessing rate.
MIN_TOKEN_BITS = 128
_EMPTY_COMPRESSED = len(zlib.compress(b"", 9))
#: Alphabets a token's characters are looked up in, smallest first: the first that holds them all is its alphabet.
_ALPHABETS: dict[str, frozenset[str]] = {
    name: frozenset(chars)
    for name, chars in (
        ("digits", string.digits),
        ("lower-case hexadecimal", string.digits + "abcdef"),
        ("upper-case hexadecimal", string.digits + "ABCDEF"),
        ("lower-case letters and digits", string.ascii_lowercase + string.digits),
        ("upper-case letters and digits", string.ascii_uppercase + string.digits),
        ("letters and digits", string.ascii_letters + string.digits),
        ("URL-safe base64", string.ascii_letters + string.digits + "-_"),
        ("printable ASCII", "".join(chr(c) for c in range(32, 127))),
    )
}


class Refused(Exception):
    """The handshake is refused with HTTP ``status`` and a reason a person can act on, after ``delay`` seconds."""

    def __init__(self, status: int, reason: str, delay: float = 0.0) -> None:
        super().__init__(reason)
        self.status = status
        self.reason = reason
        self.delay = delay


@dataclass
class Access:
    token: str | None  # None: no token needed (library use and tests), unless ``accounts``
    allow_viewers: bool = False
    allowed_origins: tuple[str, ...] = ()
    window: float = 60.0  # wrong tokens older than this (s) no longer slow an address
    #: Names the Host header may carry besides IP addresses (lower case): see ``check_host``.
    allowed_hosts: frozenset[str] = frozenset({"localhost"})
    #: People sign in (relay/net/sign_in.py): without a token, a handshake without a session is a viewer at most.
    accounts: bool = False
    _failures: dict[str, _Guesses] = field(default_factory=dict)

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

    def is_own_host(self, host: str) -> bool:
        try:
            self.check_host(host)
        except Refused:
            return False
        return True

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
        if self.token is None and not self.accounts:
            return "operator", 0.0
        if (
            presented is not None
            and self.token is not None
            and hmac.compare_digest(presented.encode(), self.token.encode())
        ):
            return "operator", 0.0  # whatever wrong tokens came from this address before
        delay = 0.0
        if presented is not None:
            delay = self.slow(address, now)
        if self.allow_viewers:
            return "viewer", delay
        if presented is None:
            if self.token is None:
                raise Refused(401, "sign in: this relay has accounts (open its page and sign in)")
            raise Refused(401, "an operator token is required: open the URL the relay printed (it ends in #token=...)")
        raise Refused(401, "wrong operator token", delay)

    def slow(self, address: str, now: float) -> float:
        """Count a wrong token (or password, or pairing code); the delay its answer waits: the spacing its count
        calls for, after the answer to the previous wrong one from this address (however many are waiting at once)."""
        guesses = self._failures.setdefault(_guesser(address), _Guesses())
        times = guesses.times
        while times and now - times[0] > self.window:
            times.popleft()
        times.append(now)
        if len(self._failures) > 10_000:
            # Bounded memory under a spray of addresses: forget the oldest entries.
            for key in list(self._failures)[:5_000]:
                del self._failures[key]
        extra = len(times) - FREE_FAILURES
        spacing = 0.0 if extra <= 0 else min(MAX_DELAY, FIRST_DELAY * 2.0 ** (extra - 1))
        wait = max(0.0, guesses.answer_at - now) + spacing
        guesses.answer_at = now + wait
        return wait


@dataclass
class _Guesses:
    """The wrong tokens of one address (or IPv6 /64) within the window, and when the last of them is answered."""

    times: deque[float] = field(default_factory=deque)
    answer_at: float = -math.inf


def _guesser(address: str) -> str:
    """Who a wrong token is counted against: the address, or an IPv6 address's /64 (one machine's block)."""
    try:
        ip = ipaddress.ip_address(address.split("%", 1)[0])
    except ValueError:
        return address
    if isinstance(ip, ipaddress.IPv6Address):
        if ip.ipv4_mapped is not None:
            return str(ip.ipv4_mapped)
        return str(ipaddress.IPv6Network((ip, 64), strict=False))
    return str(ip)


def token_bits(token: str) -> float:
    """A conservative estimate of a token's entropy in bits: its length times log2 of the smallest usual alphabet
    holding all its characters (digits, hexadecimal, letters and digits, URL-safe base64, printable ASCII; any
    other character counts as printable ASCII), that alphabet never counted larger than twice the number of
    distinct characters the token uses, and never more than 8 bits for each byte of it that zlib cannot compress
    away (``aaaa...`` is worth nothing, ``abab...`` 40 bits whatever its length, ``password`` 8 times 88). A random
    token of the relay's own (``secrets.token_urlsafe(24)``, 32 characters) scores 165 to 190 bits, ``openssl rand
    -hex 16`` 128, ``1234`` 12; compression never binds on a random token. What it cannot see is a token chosen by
    a person: a phrase of words scores far more than it is worth."""
    chars = set(token)
    size = next((len(a) for a in _ALPHABETS.values() if chars <= a), len(_ALPHABETS["printable ASCII"]))
    size = min(size, 2 * len(chars)) if len(chars) > 1 else 1
    compressed = len(zlib.compress(token.encode(), 9)) - _EMPTY_COMPRESSED
    return min(len(token) * math.log2(size), 8.0 * compressed)


def weak_token(token: str) -> str | None:
    """Why ``token`` is too weak for the command line (under :data:`MIN_TOKEN_BITS`), or None."""
    bits = token_bits(token)
    if bits >= MIN_TOKEN_BITS:
        return None
    why = f"about {bits:.0f} bits of entropy ({len(token)} characters), under the {MIN_TOKEN_BITS} the relay asks for"
    # One address guessing at the slowed rate (MAX_DELAY apart) searches half the space in this long on average.
    hours = 2.0**bits / 2 * MAX_DELAY / 3600
    if hours < 48:
        return f"{why}: one address guessing at the slowed rate finds it in {hours:.1f} hours on average"
    if hours < 24 * 3650:
        return f"{why}: one address guessing at the slowed rate finds it in {hours / 24:.0f} days on average"
    return why
