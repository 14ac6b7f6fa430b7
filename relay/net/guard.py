"""Connections before they are admitted: header timeouts, a cap on unadmitted connections, a descriptor reserve.

aiohttp waits for a request's headers without a deadline, so a client that opens connections and sends its
headers one byte a minute (slowloris) kept them open for as long as it liked; with the process's descriptors
gone, accept() failed in a loop (100k tracebacks in 20 s) and the operator could not connect. The guard:

- **deadlines**: a connection must complete its request's headers within ``header_timeout`` of being accepted
  (and of its previous response, on a kept-alive connection), or it is closed;
- **a cap on unadmitted connections**: connections that are not an admitted WebSocket (still sending headers,
  waiting for a slowed wrong-token answer, fetching a file) number at most ``max_unadmitted``; one more closes
  the oldest of them, so a flood of half-open connections evicts itself, never a newcomer;
- **a descriptor reserve**: all connections together stay ``reserve`` descriptors below the process's limit
  (``RLIMIT_NOFILE``, raised to its hard limit at start-up), leaving room for files, DDS and the operator's
  connection: at the limit the oldest unadmitted connection is closed to make room;
- **accept failures** (out of descriptors despite all this) are logged once per ``ACCEPT_LOG_PERIOD`` with a
  count, not once per try.

An admitted WebSocket (operator or viewer, ``admitted``) is never evicted by the guard. Time is the loop's
monotonic clock; the sweep runs every ``SWEEP_PERIOD``. Tested in tests/test_guard.py.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

logger = logging.getLogger(__name__)

HEADER_TIMEOUT = 10.0
MAX_UNADMITTED = 256
SWEEP_PERIOD = 0.25
ACCEPT_LOG_PERIOD = 10.0
ACCEPT_FAILURE = "socket.accept() out of system resource"


def descriptor_budget() -> tuple[int, int]:
    """Raise the soft descriptor limit to the hard one; return (limit, reserve kept for everything else)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    target = hard if hard != resource.RLIM_INFINITY else max(soft, 65536)
    if soft < target:
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
            soft = target
    return soft, max(48, soft // 8)


@dataclass
class _Connection:
    transport: Any
    opened: float
    deadline: float | None  # when it is closed unless a request has started by then; None: a request runs
    admitted: bool = False


class ConnectionGuard:
    def __init__(
        self,
        header_timeout: float = HEADER_TIMEOUT,
        max_unadmitted: int = MAX_UNADMITTED,
        max_connections: int | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.header_timeout = header_timeout
        self.max_unadmitted = max_unadmitted
        if max_connections is None:
            limit, reserve = descriptor_budget()
            max_connections = limit - reserve
        self.max_connections = max_connections
        self._clock = clock
        self._connections: dict[int, _Connection] = {}  # id(handler) -> connection
        self.timed_out = 0
        self.evicted = 0
        self._sweeper: asyncio.Task[None] | None = None
        self._accept_failures = 0
        self._accept_logged = -float("inf")

    # -- hooks ------------------------------------------------------------------------------------

    def attach(self, server: Any) -> None:
        """Follow every connection of an aiohttp ``web.Server`` (``runner.server``), and watch the loop's accept
        failures. Call on the running loop, after ``runner.setup()``."""
        made, lost = server.connection_made, server.connection_lost

        def connection_made(handler: Any, transport: Any) -> None:
            made(handler, transport)
            self.opened(handler, transport)

        def connection_lost(handler: Any, exc: BaseException | None) -> None:
            self._connections.pop(id(handler), None)
            lost(handler, exc)

        server.connection_made, server.connection_lost = connection_made, connection_lost
        loop = asyncio.get_running_loop()
        previous = loop.get_exception_handler()

        def exception_handler(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
            if context.get("message") == ACCEPT_FAILURE:
                self._accept_failed(context.get("exception"))
            elif previous is not None:
                previous(loop, context)
            else:
                loop.default_exception_handler(context)

        loop.set_exception_handler(exception_handler)
        self._sweeper = loop.create_task(self._sweep(), name="connection-guard")

    def stop(self) -> None:
        if self._sweeper is not None:
            self._sweeper.cancel()

    def opened(self, handler: Any, transport: Any) -> None:
        now = self._clock()
        self._connections[id(handler)] = _Connection(transport, now, now + self.header_timeout)
        unadmitted = [c for c in self._connections.values() if not c.admitted]
        over = max(len(unadmitted) - self.max_unadmitted, len(self._connections) - self.max_connections)
        for connection in sorted(unadmitted, key=lambda c: c.opened)[: max(0, over)]:
            self.evicted += 1
            self._close(connection)
        if over > 0:
            self._log_pressure()

    def request_started(self, handler: Any) -> None:
        connection = self._connections.get(id(handler))
        if connection is not None:
            connection.deadline = None

    def request_ended(self, handler: Any) -> None:
        """A response went out: a kept-alive connection's next request must come within the timeout too."""
        connection = self._connections.get(id(handler))
        if connection is not None and not connection.admitted:
            connection.deadline = self._clock() + self.header_timeout

    def admitted(self, handler: Any) -> None:
        connection = self._connections.get(id(handler))
        if connection is not None:
            connection.admitted, connection.deadline = True, None

    # -- the rest ---------------------------------------------------------------------------------

    @property
    def counts(self) -> dict[str, int]:
        admitted = sum(1 for c in self._connections.values() if c.admitted)
        return {
            "connections": len(self._connections),
            "admitted": admitted,
            "unadmitted": len(self._connections) - admitted,
            "timed_out": self.timed_out,
            "evicted": self.evicted,
            "accept_failures": self._accept_failures,
        }

    def sweep(self) -> None:
        now = self._clock()
        for connection in list(self._connections.values()):
            if connection.deadline is not None and now > connection.deadline:
                self.timed_out += 1
                self._close(connection)

    async def _sweep(self) -> None:
        while True:
            await asyncio.sleep(SWEEP_PERIOD)
            self.sweep()

    def _close(self, connection: _Connection) -> None:
        # abort: no lingering, no waiting for a peer that may never read; connection_lost forgets it.
        with contextlib.suppress(Exception):
            connection.transport.abort()
        connection.deadline = None

    def _log_pressure(self) -> None:
        now = self._clock()
        if now - self._accept_logged >= ACCEPT_LOG_PERIOD:
            self._accept_logged = now
            logger.warning(
                "connection flood: %d connections (%d unadmitted, at most %d; %d in all): closed the oldest "
                "unadmitted ones (%d so far)",
                len(self._connections), sum(1 for c in self._connections.values() if not c.admitted),
                self.max_unadmitted, self.max_connections, self.evicted,
            )  # fmt: skip

    def _accept_failed(self, exc: object) -> None:
        self._accept_failures += 1
        now = self._clock()
        if now - self._accept_logged >= ACCEPT_LOG_PERIOD:
            self._accept_logged = now
            logger.error(
                "cannot accept connections: %s (%d failures so far; asyncio retries after 1 s); %s",
                exc, self._accept_failures, self.counts,
            )  # fmt: skip
