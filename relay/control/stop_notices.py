"""Who follows the robots' stops: missions, which pause or abort when their robot is stopped, and keep the leases
of the robots they hold. Control tells it of every stop; the parts that follow register when they are built."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Protocol

logger = logging.getLogger(__name__)


class StopListener(Protocol):
    def __call__(self, robot: str, reason: str, *, estop: bool) -> None: ...


class StopNotices:
    def __init__(self) -> None:
        self._listeners: list[StopListener] = []
        self._holders: list[Callable[[], set[str]]] = []

    def follow(self, listener: StopListener, holds: Callable[[], set[str]]) -> None:
        """``listener`` is told of every stop (it must return at once: it runs on the estop's path); ``holds``
        names the robots whose leases must not expire although idle (on a mission: dwelling, capturing)."""
        self._listeners.append(listener)
        self._holders.append(holds)

    def stopped(self, robot: str, reason: str, *, estop: bool) -> None:
        """Every follower learns of this stop; a follower's failure is its own, never the stop's."""
        for listener in self._listeners:
            try:
                listener(robot, reason, estop=estop)
            except Exception:
                logger.exception("after stopping %s (%s), telling its mission failed", robot, reason)

    def held(self) -> set[str]:
        return set().union(*(holds() for holds in self._holders))
