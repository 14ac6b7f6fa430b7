"""Pools for the relay's heavy work (planning, rendering), each with its own threads and a bounded queue.

Heavy work once ran on asyncio's default thread pool, which anything can fill: a viewer's snapshot renders then
queued ahead of an operator's goal planning. Each kind of work now has its own pool; a pool whose workers and
queue are full refuses at once (``Busy``, an ``error`` with code ``busy`` for the client) instead of growing a
queue without bound. Stops never use a pool: an estop is a direct call on the event loop (relay.control.control).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


class Busy(Exception):
    """The pool's workers and queue are full."""


class WorkPool:
    def __init__(self, name: str, workers: int, queue: int) -> None:
        self.name = name
        self.capacity = workers + queue  # jobs running or waiting
        self.pending = 0
        self._executor = concurrent.futures.ThreadPoolExecutor(max_workers=workers, thread_name_prefix=name)

    async def run(self, fn: Callable[[], T]) -> T:
        """``fn()`` on one of the pool's threads; raises ``Busy`` when ``capacity`` jobs are already pending."""
        if self.pending >= self.capacity:
            raise Busy(f"the relay's {self.name} pool is full ({self.pending} jobs running or waiting)")
        self.pending += 1
        try:
            return await asyncio.get_running_loop().run_in_executor(self._executor, fn)
        finally:
            self.pending -= 1

    def shutdown(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)
