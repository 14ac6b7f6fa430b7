"""Debian's PostgreSQL server binaries for the store's tests (installed once when missing and allowed)."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path


def postgres_binaries() -> tuple[Path | None, str]:
    """Debian's PostgreSQL binaries (the newest major version), installing the package once if it is missing."""

    def newest() -> Path | None:
        found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"), key=lambda p: p.parent.parent.name.zfill(4))
        return found[-1].parent if found and (found[-1].parent / "pg_ctl").exists() else None

    if (binaries := newest()) is not None:
        return binaries, ""
    if os.geteuid() != 0 or shutil.which("apt-get") is None:
        return None, "no PostgreSQL server in /usr/lib/postgresql, and apt-get cannot install one here (not root)"
    try:
        done = subprocess.run(
            ["apt-get", "install", "-y", "-q", "postgresql"],
            capture_output=True,
            text=True,
            timeout=500,
            env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"},
        )
        why = (done.stderr.strip().splitlines() or ["no output"])[-1]
    except subprocess.TimeoutExpired:
        why = "it took over 500 s"
    return newest(), f"no PostgreSQL server: `apt-get install -y postgresql` failed ({why})"
