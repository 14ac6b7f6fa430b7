"""Files written whole or not at all: to a temporary name in the same folder, flushed to disk, then renamed over the
old one, so that a crash mid-write leaves the old file whole and a power cut never an empty one. Blocking: call it
off the event loop."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO


def write_atomically(path: Path, write: Callable[[IO[bytes]], None]) -> None:
    """``write`` fills the new file (binary); ``path`` is replaced once it is on disk."""
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as out:
            write(out)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
