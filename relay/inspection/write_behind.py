"""Records stored after the fact (missions, alerts): a change of state never waits for the database.

An estop once waited 15 s for a locked SQLite file (each mission's abort written one after another, 5 s busy
timeout each), and with PostgreSQL stopped it closed the operator's connection with no ack. A mission's state now
changes in memory and reaches every client at once; its record is handed here and written by one task, in order,
on the store's own thread. Records are whole (an upsert of the mission), so only the newest of each mission needs
writing: a burst of changes costs one write each, and what waits is bounded by the number of missions.

A write that fails is kept (unless a newer record of that mission came meanwhile) and tried again with a growing
pause (0.5 s to 10 s); ``failure`` says why meanwhile (``/healthz``), and one log line says so per failure streak.
Nothing is dropped: at shutdown ``close`` tries what is left, for a bounded time, and names what it could not write.
Alerts (relay.inspection.alerts) are stored the same way: raising one is on paths that must not wait.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Generic, Protocol, TypeVar

logger = logging.getLogger(__name__)

#: Seconds between tries of a failing write: doubling from the first to the last.
RETRY_FIRST, RETRY_LAST = 0.5, 10.0


class Identified(Protocol):
    @property
    def id(self) -> str: ...


R = TypeVar("R", bound=Identified)


class WriteBehind(Generic[R]):
    """``what``: the records' name in log lines and ``failure`` ("mission records", "alerts")."""

    def __init__(self, write: Callable[[R], Awaitable[None]], what: str = "mission records") -> None:
        self._write = write
        self._what = what
        self._pending: dict[str, R] = {}
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        #: Why the last write failed, while records wait for a retry (None: the store is keeping up).
        self.failure: str | None = None

    def put(self, record: R) -> None:
        """Store ``record`` soon; returns at once."""
        self._pending.pop(record.id, None)  # re-inserted last: records are written in the order of their changes
        self._pending[record.id] = record
        self._wake.set()

    @property
    def waiting(self) -> int:
        return len(self._pending)

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name=f"write-behind {self._what}")

    async def _run(self) -> None:
        pause = RETRY_FIRST
        while True:
            await self._wake.wait()
            self._wake.clear()
            if await self._drain():
                pause = RETRY_FIRST
                continue
            await asyncio.sleep(pause)
            pause = min(RETRY_LAST, pause * 2)
            self._wake.set()

    async def _drain(self) -> bool:
        """Write what waits, oldest change first; False at the first failure (the rest waits for the retry)."""
        while self._pending:
            record_id, record = next(iter(self._pending.items()))
            try:
                await self._write(record)
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                if self.failure is None:
                    logger.error(
                        "inspection database: %s %s not stored yet, will retry: %s", self._what, record_id, exc
                    )
                self.failure = f"{self._what} not stored yet ({len(self._pending)} waiting): {exc}"[:400]
                return False
            if self._pending.get(record_id) is record:
                del self._pending[record_id]
            if self.failure is not None:
                logger.warning("inspection database: %s are being stored again", self._what)
                self.failure = None
        return True

    async def close(self, timeout: float = 5.0) -> None:  # noqa: ASYNC109 - a bound on shutdown, not a caller timeout
        """Stop the task, then write what is left within ``timeout`` s; what could not be written is named."""
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self._drain(), timeout)
        if self._pending:
            logger.error(
                "inspection database: %d %s could not be stored before shutdown: %s",
                len(self._pending),
                self._what,
                ", ".join(_named(r) for r in self._pending.values())[:400],
            )


def _named(record: Identified) -> str:
    state = getattr(record, "state", None)
    return record.id if state is None else f"{record.id} ({state})"
