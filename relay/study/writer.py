"""A study's runs written off the relay's loop: the newest state of each participant waits for one writer task,
which hands it to a thread (relay/study/store.py writes and fsyncs), so that at most one write per participant is
ever queued, however often a run changes, and nothing on the loop waits for a disk."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Mapping
from typing import Any

from .store import RunStore

logger = logging.getLogger(__name__)


class RunWriter:
    def __init__(self, store: RunStore) -> None:
        self.store = store
        self._dirty: dict[str, Mapping[str, Any]] = {}  # participant -> the newest state not yet written
        self._active: str | None = None  # the participant to name active, not yet written
        self._wake = asyncio.Event()
        self._closing = False
        self._task: asyncio.Task[None] | None = None

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run(), name="study-writer")

    def put(self, participant: str, saved: Mapping[str, Any], *, active: bool = False) -> None:
        """The run's state as it is now (``StudyRun.saved``: a copy); ``active``: the relay now drives this run."""
        self._dirty[participant] = saved
        if active:
            self._active = participant
        self._wake.set()

    async def close(self) -> None:
        """Stop the writer once what is waiting is written (never cancelled in a write: a later one must not overtake
        it)."""
        self._closing = True
        self._wake.set()
        if self._task is not None:
            await self._task
            self._task = None

    def _take(self) -> tuple[dict[str, Mapping[str, Any]], str | None]:
        dirty, active = self._dirty, self._active
        self._dirty, self._active = {}, None
        return dirty, active

    def _write(self, dirty: Mapping[str, Mapping[str, Any]], active: str | None) -> None:
        for participant, saved in dirty.items():
            self.store.write(participant, saved)
        if active is not None:
            self.store.set_active(active)

    async def _run(self) -> None:
        while True:
            await self._wake.wait()
            self._wake.clear()
            dirty, active = self._take()
            try:
                if dirty or active is not None:
                    await asyncio.to_thread(self._write, dirty, active)
            except OSError:
                logger.exception(
                    "study: a run could not be saved in %s; its next change tries again", self.store.folder
                )
                if self._closing:
                    return
                for participant, saved in dirty.items():
                    self._dirty.setdefault(participant, saved)
                self._active = self._active or active
            if self._closing and not self._dirty and self._active is None:
                return
