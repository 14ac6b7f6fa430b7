"""What every benchmark shares: where results go, facts about the machine, percentiles, process CPU and
memory read from /proc, child processes that are always killed, and target records for the report.

Times are taken with ``time.monotonic()`` everywhere, including in child processes: on Linux it is
CLOCK_MONOTONIC, one clock for every process of the machine, so a stamp taken in one process can be
subtracted from a receive time taken in another.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib.metadata
import json
import os
import platform
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"
#: Quick runs and logs go under bench/results/scratch/, which git ignores: a development run never changes
#: the committed figures.
TMP = RESULTS / "scratch"
LOGS = TMP / "logs"
DOCS = ROOT / "docs"
FISHEYE = ROOT.parent / "shared" / "data" / "fisheye" / "surroundvision_jeyp4"
FISHEYE_PHOTOS = ("front.jpg", "left.jpg", "rear.jpg", "right.jpg")
#: The operator token the bench relays are started with (when this relay version has tokens).
TOKEN = "bench-token"

JsonDict = dict[str, Any]


@dataclass(frozen=True)
class Settings:
    """One run of the benchmarks: quick or full, and where its files go."""

    quick: bool
    out: Path  # the JSON results
    img: Path  # the plots
    doc: Path  # the generated page
    only: tuple[str, ...] = ()

    @classmethod
    def create(cls, quick: bool, only: Sequence[str] = ()) -> Settings:
        if quick:
            base = TMP / "quick"
            return cls(True, base, base / "img", base / "benchmarks.md", tuple(only))
        return cls(False, RESULTS, DOCS / "img", DOCS / "benchmarks.md", tuple(only))

    def pick(self, full: float, quick: float) -> float:
        return quick if self.quick else full


def summary(values: Sequence[float] | np.ndarray, scale: float = 1000.0) -> JsonDict:
    """Count, median, p95, p99, max and mean of ``values`` times ``scale`` (seconds to ms by default)."""
    data = np.asarray(values, dtype=np.float64)
    if data.size == 0:
        return {"n": 0, "p50": None, "p95": None, "p99": None, "max": None, "mean": None}
    p50, p95, p99 = np.percentile(data, [50, 95, 99])
    return {
        "n": int(data.size),
        "p50": round(float(p50) * scale, 3),
        "p95": round(float(p95) * scale, 3),
        "p99": round(float(p99) * scale, 3),
        "max": round(float(data.max()) * scale, 3),
        "mean": round(float(data.mean()) * scale, 3),
    }


class ProcStat:
    """CPU time (every thread) and resident memory of one process, from /proc: no psutil needed."""

    CLOCK_TICKS = os.sysconf("SC_CLK_TCK")

    def __init__(self, pid: int) -> None:
        self.pid = pid

    def cpu(self) -> float:
        """User + system seconds so far."""
        try:
            text = Path(f"/proc/{self.pid}/stat").read_text()
        except OSError:
            return float("nan")
        # The command name (field 2) may contain spaces: split after its closing parenthesis.
        fields = text[text.rindex(")") + 2 :].split()
        return (int(fields[11]) + int(fields[12])) / self.CLOCK_TICKS

    def rss(self) -> int:
        """Resident set size in bytes."""
        try:
            for line in Path(f"/proc/{self.pid}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
        except OSError:
            pass
        return 0


class CpuWindow:
    """CPU use of a set of processes over a window, as a fraction of one core (1.0 = one core busy)."""

    def __init__(self, pids: dict[str, int]) -> None:
        self._stats = {name: ProcStat(pid) for name, pid in pids.items()}
        self._start: dict[str, float] = {}
        self._t0 = 0.0
        self._own0 = 0.0

    def start(self) -> None:
        self._t0 = time.monotonic()
        self._own0 = time.process_time()
        self._start = {name: stat.cpu() for name, stat in self._stats.items()}

    def stop(self) -> JsonDict:
        wall = time.monotonic() - self._t0
        result: JsonDict = {
            name: round((stat.cpu() - self._start[name]) / wall, 3) for name, stat in self._stats.items()
        }
        # This process hosts the load-generating clients: when it is saturated, the figures are the
        # clients' limit, not the server's.
        result["load_generator"] = round((time.process_time() - self._own0) / wall, 3)
        result["wall"] = round(wall, 3)
        return result


def machine() -> JsonDict:
    model = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    memory = 0
    with contextlib.suppress(OSError):
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                memory = int(line.split()[1]) * 1024
    return {
        "cpu": model,
        "cores": os.cpu_count(),
        "cores_usable": len(os.sched_getaffinity(0)),
        "memory_gib": round(memory / 2**30, 1),
        "kernel": platform.release(),
        "system": platform.platform(),
        # Other work on a shared machine shows here: the reason absolute times drift between runs.
        "load_average": [round(x, 2) for x in os.getloadavg()],
    }


PACKAGES = (
    "aiohttp",
    "websockets",
    "orjson",
    "numpy",
    "opencv-python-headless",
    "rclpy",
    "ros-rmw-fastrtps-cpp",
    "foxglove-sdk",
    "playwright",
    "matplotlib",
)


def versions() -> JsonDict:
    result: JsonDict = {"python": platform.python_version(), "xr-relay": _version("xr-relay")}
    for name in PACKAGES:
        result[name] = _version(name)
    chromium = Path("/usr/bin/chromium")
    if chromium.exists():
        with contextlib.suppress(OSError, subprocess.SubprocessError):
            result["chromium"] = subprocess.run(
                [str(chromium), "--version"], capture_output=True, text=True, timeout=20, check=False
            ).stdout.strip()
    with contextlib.suppress(OSError, subprocess.SubprocessError):
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
        dirty = subprocess.run(["git", "status", "--porcelain", "relay"], cwd=ROOT, capture_output=True, text=True)
        result["git"] = head.stdout.strip() + ("+uncommitted relay/ changes" if dirty.stdout.strip() else "")
    return result


def _version(name: str) -> str | None:
    try:
        return importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        return None


def target(name: str, goal: str, measured: str, met: bool | None, reason: str = "", baseline: str = "") -> JsonDict:
    """One target as the report shows it; ``met`` None means it could not be measured (``reason`` says why)."""
    return {"name": name, "target": goal, "measured": measured, "met": met, "reason": reason, "baseline": baseline}


def write_result(settings: Settings, name: str, data: JsonDict) -> Path:
    settings.out.mkdir(parents=True, exist_ok=True)
    path = settings.out / f"{name}.json"
    path.write_text(json.dumps(data, indent=1, sort_keys=False) + "\n")
    return path


def new_ros_domain() -> int:
    """A DDS domain of its own for each run, so that concurrent test runs are never seen (0-232 are valid;
    the tests draw from 20-120)."""
    return random.randint(140, 230)


def ros_env(domain: int) -> dict[str, str]:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def child_env(extra: dict[str, str] | None = None) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.update(extra or {})
    return env


def _log_file(name: str) -> Any:
    LOGS.mkdir(parents=True, exist_ok=True)
    return open(LOGS / f"{name}.log", "ab")


@dataclass
class Child:
    """A child process that prints JSON lines on stdout and takes one-word commands on stdin.

    Its stderr goes to bench/results/scratch/logs/<name>.log. ``stop`` (always called in a ``finally``)
    ends it: stdin closed, then SIGTERM, then SIGKILL.
    """

    name: str
    process: asyncio.subprocess.Process
    lines: list[JsonDict] = field(default_factory=list)
    _changed: asyncio.Event = field(default_factory=asyncio.Event)
    _reader: asyncio.Task[None] | None = None

    @classmethod
    async def start(cls, name: str, args: Sequence[str], env: dict[str, str] | None = None) -> Child:
        with _log_file(name) as log:
            process = await asyncio.create_subprocess_exec(
                sys.executable,
                *args,
                stdin=asyncio.subprocess.PIPE,
                stdout=asyncio.subprocess.PIPE,
                stderr=log,
                env=env or child_env(),
                cwd=ROOT,
                limit=2**22,
            )
        child = cls(name, process)
        child._reader = asyncio.get_running_loop().create_task(child._read())
        return child

    @property
    def pid(self) -> int:
        return self.process.pid

    async def _read(self) -> None:
        assert self.process.stdout is not None
        async for raw in self.process.stdout:
            with contextlib.suppress(ValueError):
                self.lines.append(json.loads(raw))
                self._changed.set()
        self._changed.set()

    async def wait_for(self, predicate: Callable[[JsonDict], bool], within: float, start: int = 0) -> JsonDict:
        deadline = time.monotonic() + within
        index = start
        while True:
            while index < len(self.lines):
                line = self.lines[index]
                index += 1
                if predicate(line):
                    return line
            remaining = deadline - time.monotonic()
            ended = self._reader is not None and self._reader.done()
            if remaining <= 0 or ended:
                what = "ended its output" if ended else f"printed no expected line within {within} s"
                raise TimeoutError(f"{self.name} {what}; see {LOGS / (self.name + '.log')}")
            self._changed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._changed.wait(), remaining)

    async def request(self, command: str, within: float = 10.0) -> JsonDict:
        """Send a command line; its reply is the next line with ``"reply": command``."""
        start = len(self.lines)
        assert self.process.stdin is not None
        self.process.stdin.write(command.encode() + b"\n")
        await self.process.stdin.drain()
        return await self.wait_for(lambda line: line.get("reply") == command, within, start)

    async def stop(self, within: float = 3.0) -> int | None:
        process = self.process
        if process.returncode is None:
            if process.stdin is not None:
                with contextlib.suppress(OSError, RuntimeError):
                    process.stdin.close()
            with contextlib.suppress(ProcessLookupError):
                process.send_signal(signal.SIGTERM)
            try:
                await asyncio.wait_for(process.wait(), within)
            except TimeoutError:
                with contextlib.suppress(ProcessLookupError):
                    process.kill()
                await process.wait()
        if self._reader is not None:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await asyncio.wait_for(self._reader, 2.0)
        return process.returncode


class Report:
    """The benchmark's own report output: one line per measurement, on stdout."""

    def __init__(self, name: str) -> None:
        self.name = name

    def line(self, text: str) -> None:
        print(f"[{self.name}] {text}", flush=True)  # noqa: T201 - the benchmark's report output


def fmt(value: float | None, digits: int = 1, unit: str = "") -> str:
    if value is None or value != value:  # None or NaN
        return "n/a"
    return f"{value:.{digits}f}{unit}"


#: What the 3 x 720p runs show and what would be next, said where the target is missed.
BURSTS = (
    "250 MB/s of raw images over loopback DDS arrive in bursts after stalls of up to a few hundred ms (reliable "
    "repairs); a stream keeps up to two periods of late frames and drops the staler ones (newest wins, bounded "
    "latency). A 2.7 MB image does not fit Fast DDS's built-in 0.5 MB shared-memory segments and goes over UDP: "
    "the publisher with the relay's large-images profile (relay/backends/fastdds_large_images.xml) sends it through "
    "shared memory (the video benchmark's rows with it); or images compressed at the source (CompressedImage, "
    "166 kB, passed through at 30 fps with p50 1 ms by the camera benchmark)"
)
