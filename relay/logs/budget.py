"""Log lines about what others send us (another relay's samples, a robot's keys), bounded whatever they send.

A rogue Zenoh peer sent 3000 malformed fleet samples and the relay wrote 3000 warnings (issue 28, finding 6): the
log grows at the sender's rate. :class:`LogBudget` is the rule (pure, the time passed in): at most ``lines`` lines
per ``period``; the rest are counted, and one summary line per period names how many were left out.
:class:`BudgetedLog` applies it to a logger from any thread (Zenoh calls back on its own).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass


@dataclass
class LogBudget:
    """``lines`` per ``period`` seconds; a period starts with the first line after the previous one ended."""

    lines: int
    period: float
    start: float = -math.inf
    used: int = 0
    dropped: int = 0

    def _roll(self, now: float) -> int:
        # A clock that went backwards (it should not: callers use a monotonic one) starts a period too.
        if now - self.start >= self.period or now < self.start:
            dropped, self.start, self.used, self.dropped = self.dropped, now, 0, 0
            return dropped
        return 0

    def take(self, now: float) -> tuple[bool, int]:
        """(whether a line may be written now, how many were left out in the period that just ended: a summary of
        them goes first)."""
        dropped = self._roll(now)
        if self.used < self.lines:
            self.used += 1
            return True, dropped
        self.dropped += 1
        return False, dropped

    def overdue(self, now: float) -> int:
        """Lines left out in a period that has ended, once (0 while it runs): the summary when no line followed."""
        if self.dropped and (now - self.start >= self.period or now < self.start):
            return self._roll(now)
        return 0


class BudgetedLog:
    """A logger behind a :class:`LogBudget`, safe from any thread; ``flush`` (called now and then) writes the
    summary of a period that ended with lines left out."""

    def __init__(
        self,
        logger: logging.Logger,
        what: str,
        lines: int = 10,
        period: float = 60.0,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._logger = logger
        self._what = what
        self._budget = LogBudget(lines, period)
        self._clock = clock
        self._lock = threading.Lock()
        #: Lines left out since the start (for /healthz).
        self.dropped = 0

    def log(self, level: int, message: str, *args: object) -> None:
        with self._lock:
            allowed, dropped = self._budget.take(self._clock())
            if not allowed:
                self.dropped += 1
        self._summary(dropped)
        if allowed:
            self._logger.log(level, message, *args)

    def warning(self, message: str, *args: object) -> None:
        self.log(logging.WARNING, message, *args)

    def info(self, message: str, *args: object) -> None:
        self.log(logging.INFO, message, *args)

    def flush(self) -> None:
        with self._lock:
            dropped = self._budget.overdue(self._clock())
        self._summary(dropped)

    def _summary(self, dropped: int) -> None:
        if dropped:
            self._logger.warning(
                "%s: %d more lines like these were left out (at most %d every %.0f s)",
                self._what, dropped, self._budget.lines, self._budget.period,
            )  # fmt: skip
