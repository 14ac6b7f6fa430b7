"""Where a hung test was: shortly before pytest-timeout ends the worker, its threads' stacks and its event loops'
tasks (each down the chain of what it awaits) are written to a file of the worker's, which the report of the
worker's crash quotes.

pytest-timeout's own dump goes to the worker's stderr, which a parallel run's output does not keep: CI lost a worker
in tests/e2e/test_sound.py three times with no word of where it waited.
"""

from __future__ import annotations

import asyncio
import faulthandler
import os
import threading
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: The stacks are written this long before pytest-timeout's bound (seconds).
MARGIN_S = 20.0
#: What the report quotes of the file, at most (characters).
QUOTE_CHARS = 20_000


def stacks_file(worker: str) -> Path:
    """The file a worker writes its stacks to (``XR_TEST_STACKS``: a folder the run's controller made)."""
    return Path(os.environ["XR_TEST_STACKS"]) / f"{worker}.txt"


def awaiting(coro: Any) -> list[str]:
    """Where a suspended coroutine waits: its frame, then those of what it awaits, down to the last."""
    lines: list[str] = []
    for _ in range(100):  # a chain is a few dozen deep; a cycle would be a bug elsewhere, not a reason to hang here
        if coro is None:
            break
        frame: types.FrameType | None = getattr(coro, "cr_frame", None) or getattr(coro, "gi_frame", None)
        if frame is not None:
            lines.append(f"  {frame.f_code.co_filename}:{frame.f_lineno} in {frame.f_code.co_name}")
        coro = getattr(coro, "cr_await", None) or getattr(coro, "gi_yieldfrom", None)
    return lines


class HangReport:
    """Writes the stacks once ``after`` seconds have passed, unless cancelled first (the test ended)."""

    def __init__(self, path: Path, after: float, loops: Callable[[], list[asyncio.AbstractEventLoop]]) -> None:
        self.path = path
        self.loops = loops
        self.timer = threading.Timer(after, self._write)
        self.timer.daemon = True

    def start(self) -> None:
        self.path.unlink(missing_ok=True)
        self.timer.start()

    def cancel(self) -> None:
        self.timer.cancel()

    def _write(self) -> None:
        with self.path.open("w") as out:
            out.write("threads:\n")
            out.flush()
            faulthandler.dump_traceback(out, all_threads=True)
        try:
            loops = self.loops()
        except RuntimeError:  # the test's thread changed them meanwhile (a weak dictionary): threads only
            return
        for loop in loops:
            if not loop.is_closed():
                loop.call_soon_threadsafe(self._tasks, loop)

    def _tasks(self, loop: asyncio.AbstractEventLoop) -> None:
        with self.path.open("a") as out:
            for task in asyncio.all_tasks(loop):
                out.write(f"task {task.get_name()}:\n" + "\n".join(awaiting(task.get_coro())) + "\n")


def quote(worker: str) -> str | None:
    """What a worker wrote before it died, if anything."""
    try:
        text = stacks_file(worker).read_text(errors="replace")
    except (KeyError, OSError):
        return None
    return text[-QUOTE_CHARS:] if text else None
