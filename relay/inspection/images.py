"""Capture images as JPEG files beside the database, named by their SHA-256, never half-written.

**Images** are JPEG files beside the database, ``<images>/<sha256[:2]>/<sha256>.jpg``, written to a temporary file,
flushed to disk and renamed (never half-written), stored once however many captures share them. The file is
written before the capture's row, so a row never names a missing image.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import tempfile
from pathlib import Path

from .database import StoreError

_SHA256 = re.compile(r"[0-9a-f]{64}")


class ImageFiles:
    """The images directory ``folder`` of the database named ``database`` (for messages)."""

    def __init__(self, folder: Path, database: str) -> None:
        self.folder = folder
        self._database = database

    def keep(self, jpeg: bytes) -> str:
        """Write the JPEG unless the same bytes are there already; its SHA-256."""
        sha = hashlib.sha256(jpeg).hexdigest()
        path = self._path(sha)
        if path.exists():  # content-addressed: the same bytes are already there
            return sha
        temporary = None
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".part")
            with os.fdopen(fd, "wb") as out:
                out.write(jpeg)
                out.flush()
                os.fsync(out.fileno())  # on disk before its name is: no empty image after a power cut
            os.replace(temporary, path)
        except OSError as exc:
            if temporary is not None:
                with contextlib.suppress(OSError):
                    os.unlink(temporary)
            full = exc.errno in (errno.ENOSPC, errno.EDQUOT)
            problem = "the disk is full" if full else exc.strerror or str(exc)
            raise StoreError(f"database {self._database}: images directory {self.folder}: {problem}") from exc
        return sha

    def _path(self, sha: str) -> Path:
        return self.folder / sha[:2] / f"{sha}.jpg"

    def read(self, sha256: str) -> bytes | None:
        """The JPEG of that SHA-256 (64 lowercase hex digits, nothing else: no path), or None."""
        if not _SHA256.fullmatch(sha256):
            return None
        try:
            return self._path(sha256).read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise StoreError(f"database {self._database}: image {sha256}: {exc.strerror or exc}") from exc
