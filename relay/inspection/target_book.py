"""The site's targets: bounded, kept in the database, and announced as what changed.

Targets come from the scene's hazards and ``--targets`` at start (re-read each start), and from operators and
KML/KMZ mission files while the relay runs (stored: they outlive a restart, and a stored one replaces the scene's of
the same id). Every client gets the whole book once, after its ``hello``, and then only ``targets_changed``: the
list re-sent on every add once delayed an estop to 9.7 s. The book holds at most robots.yaml's
``inspection.max_targets``; an addition past it is refused whole.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterable
from typing import TYPE_CHECKING

from ..errors import CommandRejected
from ..session.protocol import ErrorCode, RequestId
from .messages import TargetsMessage, targets_changed_message, targets_message
from .records import Target

if TYPE_CHECKING:
    from ..station.outbox import Outbox
    from .store import Store

#: Runs a call on the store's thread; raises CommandRejected naming the database when it fails.
StoreCall = Callable[[Callable[["Store"], None], RequestId | None], Awaitable[None]]


class TargetBook:
    def __init__(self, cap: int, outbox: Outbox, store: StoreCall) -> None:
        self.cap = cap
        self._outbox, self._store = outbox, store
        #: By id. Read by missions (read-only); changed only through this class.
        self.targets: dict[str, Target] = {}
        #: New ids being stored now: counted against the cap, so that additions checked at once cannot pass it.
        self._coming: set[str] = set()

    def __len__(self) -> int:
        return len(self.targets)

    def load(self, targets: Iterable[Target], source: str) -> None:
        """At start: ``targets`` join the book (no client is connected yet). Raises ValueError past the cap."""
        targets = list(targets)
        self.refuse_past_cap(targets, source)
        self.targets.update((t.id, t) for t in targets)

    def refusal(self, targets: list[Target], source: str) -> str | None:
        """Why adding ``targets`` would pass the cap, or None."""
        new = len({t.id for t in targets} - self.targets.keys() - self._coming)
        total = len(self.targets) + len(self._coming) + new
        if total <= self.cap:
            return None
        return (
            f"{source}: {new} new targets would make {total}, more than the site's "
            f"{self.cap} (robots.yaml inspection.max_targets); nothing was added"
        )

    def refuse_past_cap(self, targets: list[Target], source: str) -> None:
        if (refusal := self.refusal(targets, source)) is not None:
            raise ValueError(refusal)

    def check(self, targets: list[Target], source: str, request_id: RequestId | None) -> None:
        """Raises CommandRejected (``bad_request``) when ``targets`` would not fit."""
        if (refusal := self.refusal(targets, source)) is not None:
            raise CommandRejected(ErrorCode.BAD_REQUEST, refusal, request_id)

    async def add(self, targets: list[Target], source: str, request_id: RequestId | None) -> list[Target]:
        """Add or replace ``targets``, all or none: stored first (a database that fails adds nothing), then every
        client is told what changed."""
        self.check(targets, source, request_id)
        coming = {t.id for t in targets} - self.targets.keys() - self._coming
        self._coming |= coming  # held against the cap while the database works
        try:
            await self._store(lambda store: store.save_targets(targets), request_id)
        finally:
            self._coming -= coming
        self.targets.update((t.id, t) for t in targets)
        self._outbox.broadcast(targets_changed_message(targets))
        return targets

    def message(self) -> TargetsMessage:
        """The whole book, for a client that just connected."""
        return targets_message(list(self.targets.values()))
