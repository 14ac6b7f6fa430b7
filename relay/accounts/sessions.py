"""Who is signed in: sessions behind an HttpOnly cookie, and the short codes that pair a headset with a signed-in
desktop. Pure: the time is passed in; the routes are relay/net/sign_in.py.

A session is a random id (256 bits) that the browser holds in a cookie its scripts cannot read, and a CSRF token
that the page reads once (from the sign-in answer) and sends back in a header with every state-changing request:
a page of another site can make the browser send the cookie, never read the token. A session ends when signed out,
idle for :data:`IDLE` or :data:`LIFETIME` after sign-in, when its user is removed or their role changes (the relay
ends their sessions), and with the relay (kept in memory: a restart signs everyone in again).

A pairing code lets a headset, where typing a password is slow, take the session of the person signed in on the
desktop: the desktop asks for a code (6 characters of an alphabet without look-alikes), the headset's page sends it
within :data:`CODE_LIFETIME`, once. Guessing one is slowed as wrong passwords are (relay/net/access.py).
"""

from __future__ import annotations

import secrets
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Final

from ..wire.messages import Role

#: A shift: a page left signed in on the operator station's desktop stays in through it.
IDLE: Final = 12 * 3600.0
LIFETIME: Final = 24 * 3600.0
#: Sessions kept at once; one more ends the least recently used (a flood of sign-ins cannot grow memory).
MAX_SESSIONS: Final = 2000
CODE_LIFETIME: Final = 120.0
CODE_ALPHABET: Final = "ABCDEFGHJKLMNPQRSTUVWXYZ23456789"
CODE_LENGTH: Final = 6
#: Codes waiting at once, in all (each desktop asks for one at a time).
MAX_CODES: Final = 64


@dataclass(frozen=True, slots=True)
class Session:
    id: str
    user: str
    role: Role
    csrf: str
    created: float
    seen: float
    #: "desktop", or "paired" for a headset that took it by code.
    via: str = "desktop"
    #: Who vouches for the person: "local" (the users file) or "oidc" (the site's OpenID Connect provider, whose
    #: people are not in the users file: a change of that file never ends their sessions). A paired headset keeps it.
    provider: str = "local"


@dataclass(frozen=True, slots=True)
class _Code:
    session: str
    until: float


class Sessions:
    def __init__(self) -> None:
        self._sessions: OrderedDict[str, Session] = OrderedDict()
        self._codes: dict[str, _Code] = {}

    def open(self, user: str, role: Role, now: float, via: str = "desktop", provider: str = "local") -> Session:
        session = Session(secrets.token_urlsafe(32), user, role, secrets.token_urlsafe(24), now, now, via, provider)
        self._sessions[session.id] = session
        while len(self._sessions) > MAX_SESSIONS:
            self._sessions.popitem(last=False)
        return session

    def get(self, session_id: str | None, now: float) -> Session | None:
        """The live session of that id (its idle time restarted), or None."""
        session = self._sessions.get(session_id) if session_id else None
        if session is None:
            return None
        if now - session.seen > IDLE or now - session.created > LIFETIME:
            del self._sessions[session.id]
            return None
        session = replace(session, seen=now)
        self._sessions[session.id] = session
        self._sessions.move_to_end(session.id)
        return session

    def close(self, session_id: str) -> None:
        self._sessions.pop(session_id, None)
        self._codes = {c: code for c, code in self._codes.items() if code.session != session_id}

    def close_user(self, user: str) -> int:
        """End every session of the users file's ``user`` (removed, or their role changed); how many there were."""
        ended = [s.id for s in self._sessions.values() if s.provider == "local" and s.user.lower() == user.lower()]
        for session_id in ended:
            self.close(session_id)
        return len(ended)

    def end_changed(self, roles: Mapping[str, Role]) -> set[str]:
        """End the sessions of users no longer in ``roles`` (user name in lower case -> role) or whose role is not
        the one they signed in with; the names of the users whose sessions ended. A session of the site's OpenID
        Connect provider is the provider's to end (its people are not in the users file)."""
        ended = {
            s.user for s in self._sessions.values() if s.provider == "local" and roles.get(s.user.lower()) != s.role
        }
        for user in ended:
            self.close_user(user)
        return ended

    def pairing_code(self, session: Session, now: float) -> str:
        """A new code for ``session`` (the previous one of that session no longer works)."""
        self._expire_codes(now)
        self._codes = {c: code for c, code in self._codes.items() if code.session != session.id}
        if len(self._codes) >= MAX_CODES:
            oldest = min(self._codes, key=lambda c: self._codes[c].until)
            del self._codes[oldest]
        code = "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))
        self._codes[code] = _Code(session.id, now + CODE_LIFETIME)
        return code

    def claim(self, code: str, now: float) -> Session | None:
        """A headset's session for a valid ``code`` (used up), the same person and role; None otherwise."""
        self._expire_codes(now)
        entry = self._codes.pop(code.strip().upper(), None)
        if entry is None:
            return None
        desktop = self.get(entry.session, now)
        if desktop is None:
            return None
        return self.open(desktop.user, desktop.role, now, via="paired", provider=desktop.provider)

    def _expire_codes(self, now: float) -> None:
        self._codes = {c: code for c, code in self._codes.items() if code.until > now}
