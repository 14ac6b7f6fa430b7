"""Changes to the users file reach a running relay: a user removed, or given another role, by ``xr-relay users`` in
another process is signed out within :data:`PERIOD`, and their open pages are closed (code :data:`CLOSE_CODE`), so
that a removed operator's page stops commanding at once and a promoted viewer's reconnects with the new role.

The file is looked at (its modification time and size) off the event loop every :data:`PERIOD`, and read only when
it changed; a file that cannot be read leaves every session as it is and is said once in the log.
"""

from __future__ import annotations

import asyncio
import logging
import os
from collections.abc import Awaitable, Callable
from typing import Final

from ..accounts.sessions import Sessions
from ..accounts.users import UserBook

logger = logging.getLogger(__name__)

#: How long a removed user's sessions outlive the change, at most (seconds).
PERIOD: Final = 2.0
#: The close code of a page whose account changed: the page asks who it is (GET /whoami) and signs in again.
CLOSE_CODE: Final = 4401

Close = Callable[[int, bytes], Awaitable[object]]


class AccountWatch:
    def __init__(self, book: UserBook, sessions: Sessions, period: float = PERIOD) -> None:
        self._book = book
        self._sessions = sessions
        self._period = period
        self._pages: dict[str, set[Close]] = {}
        self._seen: tuple[int, int] | None = None
        self._failing = False

    def attach(self, user: str, close: Close) -> Callable[[], None]:
        """A signed-in page opened: ``close`` ends it if its account changes. Returns what forgets it."""
        pages = self._pages.setdefault(user.lower(), set())
        pages.add(close)

        def forget() -> None:
            pages.discard(close)
            if not pages:
                self._pages.pop(user.lower(), None)

        return forget

    async def run(self) -> None:
        """Until cancelled: look at the file every period, and apply what changed."""
        self._seen = await asyncio.to_thread(self._stamp)
        while True:
            await asyncio.sleep(self._period)
            await self.check()

    async def check(self) -> set[str]:
        """Look once; end the sessions and close the pages of every user removed or given another role."""
        stamp = await asyncio.to_thread(self._stamp)
        if stamp == self._seen:
            return set()
        try:
            users = await asyncio.to_thread(self._book.users)
        except Exception as exc:  # a file being written, or broken: keep everyone as they are, say it once
            if not self._failing:
                logger.warning("accounts: cannot read %s (%s): sessions kept as they are", self._book.path, exc)
            self._failing = True
            return set()
        self._seen, self._failing = stamp, False
        ended = self._sessions.end_changed({u.name.lower(): u.role for u in users})
        for user in sorted(ended):
            pages = list(self._pages.pop(user.lower(), ()))
            logger.info("accounts: %s removed or given another role: signed out, %d page(s) closed", user, len(pages))
            await asyncio.gather(
                *(close(CLOSE_CODE, b"your account changed: sign in again") for close in pages), return_exceptions=True
            )
        return ended

    def _stamp(self) -> tuple[int, int] | None:
        try:
            info = os.stat(self._book.path)
        except OSError:
            return None
        return info.st_mtime_ns, info.st_size
