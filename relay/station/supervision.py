"""The relay's heartbeat: timeouts that stop robots, statuses that age, and a failed backend's recovery.

:meth:`Supervisor.tick` is one beat with the time passed in (tested without sleeping); :meth:`Supervisor.run`
calls it every ``DEADMAN_PERIOD`` on the loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Sequence

from ..backends.base import Backend
from ..control.arm_control import ArmControl
from ..control.control import Control
from .outbox import Outbox

logger = logging.getLogger(__name__)

#: How often the deadman is checked; with a 0.5 s timeout a silent operator's robot stops within 0.55 s.
DEADMAN_PERIOD = 0.05
#: How often every robot's status (its data age) is sent even when nothing else changed.
STATUS_PERIOD = 1.0
#: How often a failed backend is asked to recover.
RECOVERY_PERIOD = 3.0


class Supervisor:
    def __init__(
        self,
        robots: Sequence[str],
        backend: Backend,
        control: Control,
        arms: ArmControl,
        outbox: Outbox,
        clock: Callable[[], float],
    ) -> None:
        self._robots = list(robots)
        self._backend = backend
        self._control = control
        self._arms = arms
        self._outbox = outbox
        self._clock = clock
        self._next_status = -float("inf")
        self._next_recovery = -float("inf")
        self._reported_failure: str | None = None
        self._task: asyncio.Task[None] | None = None

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name="relay-ticker")

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    async def tick(self, now: float) -> None:
        await self._control.expire(now)
        await self._arms.expire(now)
        for robot in self._robots:
            if self._outbox.online_changed(robot, now):
                self._outbox.status(robot, now)
        if now >= self._next_status:
            self._next_status = now + STATUS_PERIOD
            for robot in self._robots:
                self._outbox.status(robot, now)
            await self.watch_backend(now)

    async def watch_backend(self, now: float) -> None:
        """Report a backend failure (and its end) to every client, and keep trying to recover."""
        failure = self._backend.failure
        if failure != self._reported_failure:
            self._reported_failure = failure
            if failure:
                logger.error("backend %s failed: %s", self._backend.name, failure)
            self._outbox.backend(self._backend.name, failure)
        if failure and now >= self._next_recovery:
            self._next_recovery = now + RECOVERY_PERIOD
            try:
                await self._backend.recover()
            except Exception:
                logger.exception(
                    "backend %s could not recover; retrying in %.0f s", self._backend.name, RECOVERY_PERIOD
                )

    async def _run(self) -> None:
        while True:
            await asyncio.sleep(DEADMAN_PERIOD)
            await self.tick(self._clock())
