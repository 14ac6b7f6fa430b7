"""A recording read ahead of playback by a thread of its own, into a bounded buffer the loop plays from.

The part every replayed recording shares (a rosbag2 bag, relay/backends/bag/reader.py; a station session,
relay/replay/reader.py): the thread opens the file, waits for the plan of what to read, and reads from the playback
position in passes, one per seek; the loop peeks and pops what is due. A subclass says how to open its file
(:meth:`ReadAhead._open`), what to prepare once the plan is known (:meth:`ReadAhead._prepare`) and how to read one
pass (:meth:`ReadAhead._pass`, which pushes :class:`~relay.backends.bag.decoding._Item` s with :meth:`ReadAhead._push`).
"""

from __future__ import annotations

import abc
import asyncio
import collections
import concurrent.futures
import contextlib
import logging
import threading
from typing import Generic, TypeVar

from ...errors import BackendUnavailable
from .decoding import _Item

logger = logging.getLogger(__name__)

#: The reader stays at most this many events, image bytes, or seconds of the recording ahead of playback, and
#: refills once half of that was played: decoding in chunks, at the pace of playback, never the whole file.
MAX_BUFFERED_ITEMS = 5000
MAX_BUFFERED_BYTES = 64 * 1024 * 1024
MAX_BUFFERED_SECONDS = 10.0

Contents = TypeVar("Contents")
Plan = TypeVar("Plan")


class ReadAhead(abc.ABC, Generic[Contents, Plan]):
    """One recording: its reader thread and the bounded buffer of events it fills ahead of playback.

    ``_cond`` guards ``_buffer``, ``_bytes``, ``_generation``, ``_start``, ``_plan`` and ``_stopped``. The thread
    owns the file's reader. The loop calls :meth:`play`, :meth:`restart`, :meth:`peek`, :meth:`pop` and
    :meth:`close`, which hold the lock only for a few operations and never wait. Every seek starts a new
    generation: the buffer is emptied and the thread abandons its pass and reads from the target.
    """

    def __init__(self, name: str, shown: str, loop: asyncio.AbstractEventLoop) -> None:
        """``name``: the file's name (threads, tasks); ``shown``: how errors name it."""
        self.name = name
        self.shown = shown
        #: What the file holds, once the thread opened it; a BackendUnavailable naming the file when it cannot.
        self.opened: concurrent.futures.Future[Contents] = concurrent.futures.Future()
        #: Set on the loop when the buffer gains an item after being empty, and on every playback change.
        self.ready = asyncio.Event()
        self._loop = loop
        self._cond = threading.Condition()
        self._buffer: collections.deque[_Item] = collections.deque()
        self._bytes = 0
        self._generation = 0
        self._start = 0.0
        self._plan: Plan | None = None
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name=f"read-{name}", daemon=True)

    # -- loop side --------------------------------------------------------------------------------

    def start_thread(self) -> None:
        self._thread.start()

    def play(self, plan: Plan, start: float) -> None:
        with self._cond:
            self._plan = plan
            self._start = start
            self._generation += 1
            self._cond.notify_all()

    def restart(self, start: float) -> None:
        """Drop what was read ahead and read again from ``start`` (s from the recording's first message)."""
        with self._cond:
            self._generation += 1
            self._start = start
            self._buffer.clear()
            self._bytes = 0
            self._cond.notify_all()
        self.ready.set()

    def peek(self) -> _Item | None:
        with self._cond:
            return self._buffer[0] if self._buffer else None

    def pop(self) -> None:
        with self._cond:
            if self._buffer:
                self._bytes -= self._buffer.popleft().size
            if self._room(0.5):
                self._cond.notify_all()

    def close(self) -> None:
        with self._cond:
            self._stopped = True
            self._cond.notify_all()

    def join(self, timeout: float) -> None:
        if self._thread.is_alive():
            self._thread.join(timeout)

    # -- reader thread ----------------------------------------------------------------------------

    @abc.abstractmethod
    def _open(self) -> Contents:
        """Open the file and say what it holds; raise (any exception) when it cannot be read."""

    def _prepare(self, plan: Plan) -> None:
        """What to do once, when the plan is known, before the first pass."""

    @abc.abstractmethod
    def _pass(self, plan: Plan, generation: int, start: float) -> None:
        """Read from ``start`` to the end, pushing items, until :meth:`_push` returns False (a seek or stop)."""

    def _close_file(self) -> None:
        """Close what :meth:`_open` opened (on the thread, at its end)."""

    def _cannot_read(self, exc: BaseException) -> BackendUnavailable:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        return BackendUnavailable(f"{self.shown}: cannot read this recording: {reason}")

    def _wake(self) -> None:
        # The loop may be closed already at shutdown: then nobody waits.
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self.ready.set)

    def _current(self, generation: int) -> bool:
        return self._generation == generation and not self._stopped

    def _room(self, fraction: float) -> bool:
        """Whether the buffer is below ``fraction`` of its limits (call with ``_cond`` held)."""
        if not self._buffer:
            return True
        ahead = self._buffer[-1].position - self._buffer[0].position
        return (
            len(self._buffer) < MAX_BUFFERED_ITEMS * fraction
            and self._bytes < MAX_BUFFERED_BYTES * fraction
            and ahead < MAX_BUFFERED_SECONDS * fraction
        )

    def _push(self, generation: int, item: _Item) -> bool:
        """Append ``item`` once there is room; False when a seek or stop made this pass obsolete."""
        with self._cond:
            while self._current(generation) and not self._room(1.0):
                self._cond.wait()
            if not self._current(generation):
                return False
            was_empty = not self._buffer
            self._buffer.append(item)
            self._bytes += item.size
        if was_empty:
            self._wake()
        return True

    def _run(self) -> None:
        try:
            contents = self._open()
        except Exception as exc:
            self.opened.set_exception(self._cannot_read(exc))
            return
        try:
            self.opened.set_result(contents)
            with self._cond:
                while self._plan is None and not self._stopped:
                    self._cond.wait()
                plan = self._plan
            if plan is not None:
                self._prepare(plan)
                self._serve(plan)
        except Exception as exc:
            if not self.opened.done():  # start() waits on it: it must always be resolved
                self.opened.set_exception(self._cannot_read(exc))
            logger.exception("%s: the reader failed; this recording stops here", self.shown)
        finally:
            with contextlib.suppress(Exception):
                self._close_file()

    def _serve(self, plan: Plan) -> None:
        """One pass per generation (the first, then one per seek), until closed."""
        done = 0
        while True:
            with self._cond:
                while not self._stopped and self._generation == done:
                    self._cond.wait()
                if self._stopped:
                    return
                generation, start = self._generation, self._start
            self._pass(plan, generation, start)
            done = generation
