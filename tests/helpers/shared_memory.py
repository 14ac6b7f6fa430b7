"""Shared-memory segments that dead processes left in /dev/shm, removed between test runs.

Fast DDS gives each participant a segment (35 MB with the relay's large-images profile) and an `_el` file that its
process holds locked while it lives; a process that is killed, as many tests kill relays and peers on purpose,
leaves both behind. /dev/shm is memory: one fresh-clone run of the suite left 67 segments, 595 MB, and runs on one
machine added up to 6.2 GB, all of it taken from the browsers and workers of later runs. A segment whose lock file
nobody holds belongs to no living process (the rule of Fast DDS's own `fastdds shm clean`); a segment still in use,
by this run or another beside it, is locked and stays.
"""

from __future__ import annotations

import fcntl
import os
import re
from pathlib import Path

SHM = Path("/dev/shm")
#: A segment's lock file: `fastdds_<16 hex>_el` (Fast DDS 3; `fastrtps_` before).
_LOCK = re.compile(r"^fast(dds|rtps)_[0-9a-z]{16}_el$")


def _held(lock: Path) -> bool:
    try:
        with open(lock, "ab") as file:
            fcntl.flock(file, fcntl.LOCK_EX | fcntl.LOCK_NB)  # released when the file closes
        return False
    except OSError:
        return True


def remove_orphaned_segments(shm: Path = SHM) -> int:
    """Remove every Fast DDS segment of a dead process; returns how many bytes of memory that gave back."""
    try:
        names = os.listdir(shm)
    except OSError:
        return 0  # no /dev/shm (not Linux): nothing was left there
    freed = 0
    for name in names:
        if not _LOCK.match(name) or _held(shm / name):
            continue
        for path in (shm / name.removesuffix("_el"), shm / name):
            try:
                freed += path.stat().st_blocks * 512
                path.unlink()
            except OSError:
                pass  # gone already (another run cleaning too)
    return freed


def memory_report(top: int = 6) -> str:
    """The machine's free memory, what /dev/shm holds and the largest processes: said when a test worker dies
    without a word (the kernel's out-of-memory killer sends SIGKILL, which leaves no traceback)."""
    lines = []
    try:
        meminfo = dict(line.split(":", 1) for line in Path("/proc/meminfo").read_text().splitlines())
        lines.append(f"MemTotal {meminfo['MemTotal'].strip()}, MemAvailable {meminfo['MemAvailable'].strip()}")
        lines.append(f"/dev/shm holds {meminfo.get('Shmem', '?').strip()}")
    except (OSError, KeyError, ValueError):
        lines.append("no /proc/meminfo")
    sizes = []
    for pid in os.listdir("/proc") if Path("/proc").is_dir() else []:
        if not pid.isdigit():
            continue
        try:
            status = dict(line.split(":", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines())
            sizes.append((int(status["VmRSS"].split()[0]), pid, status["Name"].strip()))
        except (OSError, KeyError, ValueError):
            continue
    lines += [f"  {rss // 1024} MB  {name} ({pid})" for rss, pid, name in sorted(sizes, reverse=True)[:top]]
    return "\n".join(lines)
