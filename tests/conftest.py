"""Shared fixtures: real relays on loopback port 0, real WebSocket clients, and a loop-blocking check.

The suite runs in parallel (pytest-xdist, ``-n`` in the Makefile): every test keeps to its own port (0), its own
temporary files, its own ROS domain (disjoint between the workers of a run) and its own relay database.
"""

from __future__ import annotations

import asyncio
import atexit
import contextlib
import itertools
import logging
import os
import random
import re
import shutil
import sys
import tempfile
import threading
import time
import weakref
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import hypothesis  # noqa: F401 - imported up front: its plugin's lazy import at session end trips CPython 3.11.7
import pytest
from aiohttp import web

import relay.backends.sim  # noqa: F401 - imported once here, as the relay does at start-up: trimesh and
from relay.cli.options import Options

# Embree take a second to import, which would otherwise count as the first test's loop blocking.
from relay.config import FleetConfig, load_config
from relay.net.server import RELAY_KEY, create_app, open_runner
from relay.station.core import Relay
from tests.helpers.hang_report import MARGIN_S, HangReport, quote, stacks_file
from tests.helpers.shared_memory import memory_report, remove_orphaned_segments

#: Fixtures kept beside their helpers, for every test module: the store's databases.
pytest_plugins = ("tests.helpers.databases",)

ROOT = Path(__file__).resolve().parent.parent
#: The shared recordings, maps, photos and robot description (../shared/data beside the repository; a clone of the
#: repository alone has none). XR_SHARED_DATA points elsewhere (`XR_SHARED_DATA=/nonexistent` checks that every
#: test that needs it skips, naming it, when it is absent).
SHARED_DATA = Path(os.environ.get("XR_SHARED_DATA") or ROOT.parent / "shared" / "data")


def shared_data(*parts: str) -> Path:
    """A file or folder of the shared data; skips the test, naming what is missing, when it is not there."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"the shared data is absent: {path} (../shared/data beside the repository, or $XR_SHARED_DATA)")
    return path


#: A callback holding the loop longer than this fails the test: it would freeze every client's stream.
#: Half a second, not less: on a loaded 2-core machine, forking a subprocess or a burst of garbage
#: collection alone can hold a step for a few hundred milliseconds without any blocking call.
BLOCKING_THRESHOLD = 0.5

#: What a loaded machine may add to a time a test bounds, in seconds. The suite runs in parallel beside whatever else
#: CI runs, and a process that waits for a CPU is late by that much whatever the code does: with the suite's workers,
#: a CPU hog and other work on two cores (load average 30), a 0.1 s estop path took up to 1.9 s. A bound in a test is
#: the design's figure plus this slack, enough to catch a stop that never comes or a hang; the figures themselves
#: are measured by the benchmarks (bench/), on a quiet machine.
LOAD_SLACK = 2.0

_SLOW = re.compile(r"^Executing .* took (\d+\.\d+) seconds$", re.S)


class Canary(threading.Thread):
    """Wakes every 10 ms and notes how late it woke: the measure of the whole process being starved. It also notes
    how long the loop's thread (the one that made the canary) has waited for a CPU so far.

    A callback that blocks the loop with a sleep or blocking I/O releases the GIL, and one that computes in
    Python gives it up every 5 ms: either way the canary keeps waking on time. When the canary is late too,
    the machine (or another thread holding the GIL in C code, or holding it while it waits for a CPU) starved the
    whole process, and that part of a long callback says nothing about the relay.

    On a machine with more runnable threads than cores (tests in parallel, a busy CI), the canary, which sleeps,
    is woken at once while the loop's thread, which computes, waits its turn in the run queue: a callback of
    0.1 s of CPU then takes 0.6 s. The kernel counts that wait (/proc/.../schedstat, Linux). The time a callback
    held the loop itself is its duration less the larger of the two.
    """

    def __init__(self) -> None:
        super().__init__(name="loop-block-canary", daemon=True)
        # (wake time, lateness) of wake-ups over 10 ms late: twice the GIL's 5 ms switch interval (a callback computing
        # in Python makes the canary that late at most); later, the process was starved
        self.late: list[tuple[float, float]] = []
        self.waited: list[tuple[float, float]] = []  # (time, the loop thread's run-queue wait so far, seconds)
        self.running = True
        try:
            self._schedstat: int | None = os.open(f"/proc/self/task/{threading.get_native_id()}/schedstat", os.O_RDONLY)
        except OSError:
            self._schedstat = None  # not Linux: no run-queue figures, the canary alone decides

    def _note_wait(self) -> None:
        if self._schedstat is not None:
            # "<ns on a CPU> <ns waiting in a run queue> <time slices>"
            self.waited.append((time.monotonic(), int(os.pread(self._schedstat, 64, 0).split()[1]) / 1e9))

    def run(self) -> None:
        try:
            while self.running:
                self._note_wait()
                before = time.monotonic()
                time.sleep(0.01)
                lateness = time.monotonic() - before - 0.01
                if lateness > 0.01:
                    self.late.append((time.monotonic(), lateness))
            self._note_wait()
        finally:
            if self._schedstat is not None:
                os.close(self._schedstat)

    def starved(self, start: float, end: float) -> float:
        """How long the canary was kept from running between ``start`` and ``end`` (monotonic seconds): the part of
        each late wake's delay that falls in that span. A wake is noted when the canary runs again, which may be
        well after the span when the process stays starved (a thread of its own holding the GIL while it waits for
        a CPU): the delay is counted where it happened, not where it was noted."""
        return sum(max(0.0, min(at, end) - max(at - late, start)) for at, late in self.late)

    def queued(self, start: float, end: float) -> float:
        """How long the loop's thread waited for a CPU between ``start`` and ``end``, at most (from the samples
        around that span; 0 without figures)."""
        before = [wait for at, wait in self.waited if at <= start]
        after = [wait for at, wait in self.waited if at >= end]
        if not before or not after:
            return 0.0
        return after[0] - before[-1]


class SlowCallbackCollector(logging.Handler):
    """Collects asyncio debug-mode reports of callbacks that held the event loop."""

    def __init__(self, threshold: float) -> None:
        super().__init__(logging.WARNING)
        self.threshold = threshold
        self.reports: list[str] = []
        self.slow: list[tuple[float, float, str]] = []  # (end, duration, report)

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        match = _SLOW.match(text)
        # Playwright's driver pipe decodes whole screenshots in one step: the browser tests' machinery,
        # not the relay, and no relay runs that code.
        if match and "playwright/_impl" not in text and float(match.group(1)) >= self.threshold:
            self.reports.append(text)
            self.slow.append((time.monotonic(), float(match.group(1)), text))

    def blocking(self, canary: Canary) -> list[str]:
        """Reports of callbacks that held the loop for the threshold themselves: their duration less the time the
        process was starved (the canary late) or the loop's thread waited for a CPU while they ran."""
        held = []
        for end, took, text in self.slow:
            start = end - took
            if took - max(canary.starved(start, end), canary.queued(start, end)) >= self.threshold:
                held.append(text)
        return held


@pytest.fixture
def loop_block_collector() -> Iterator[SlowCallbackCollector]:
    collector = SlowCallbackCollector(BLOCKING_THRESHOLD)
    logger = logging.getLogger("asyncio")
    logger.addHandler(collector)
    try:
        yield collector
    finally:
        logger.removeHandler(collector)


_ASYNCIO_LOG = logging.getLogger("asyncio")
_RUN_HANDLE = asyncio.Handle._run
#: The loops whose callbacks are timed, and the duration from which one is reported.
_TIMED: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, float] = weakref.WeakKeyDictionary()


def _timed_run(handle: asyncio.Handle) -> None:
    """A callback run as asyncio's debug mode runs it: timed, and reported in debug mode's words when slow."""
    threshold = _TIMED.get(handle._loop)  # type: ignore[attr-defined]
    if threshold is None:
        _RUN_HANDLE(handle)
        return
    start = time.monotonic()
    _RUN_HANDLE(handle)  # never raises: a callback's exception goes to the loop's exception handler
    took = time.monotonic() - start
    if took >= threshold:
        _ASYNCIO_LOG.warning("Executing %s took %.3f seconds", asyncio.base_events._format_handle(handle), took)  # type: ignore[attr-defined]


def _on_the_loops_thread(loop: asyncio.AbstractEventLoop, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """``loop.<name>`` raises when called from another thread, as in debug mode (call_soon_threadsafe is the way)."""
    method = getattr(loop, name)

    def checked(*args: Any, **kwargs: Any) -> Any:
        loop._check_thread()  # type: ignore[attr-defined]
        return method(*args, **kwargs)

    monkeypatch.setattr(loop, name, checked)


@contextlib.asynccontextmanager
async def blocking_checks(
    request: pytest.FixtureRequest, collector: SlowCallbackCollector, monkeypatch: pytest.MonkeyPatch
) -> AsyncIterator[None]:
    """The two checks of asyncio's debug mode that find relay bugs, on the running loop for the length of a test: a
    callback that blocks the loop fails the test, and the loop's scheduling calls raise when made from another thread.

    Not debug mode itself: it also records where every future, handle and task was made (a walk of the stack with a
    stat() of each frame's file, at every create_future and call_soon). Profiled in a VR test, that was 16 s of the
    39 s the test's own process computed (266 k stat calls, most for Playwright's futures); CPython's C futures
    take the stack from a function they hold, so it cannot be turned off alone."""
    loop = asyncio.get_running_loop()
    _TIMED[loop] = BLOCKING_THRESHOLD
    monkeypatch.setattr(asyncio.Handle, "_run", _timed_run)
    for name in ("call_soon", "call_at"):
        _on_the_loops_thread(loop, name, monkeypatch)
    canary = Canary()
    canary.start()
    yield
    canary.running = False
    _TIMED.pop(loop, None)
    blocking = collector.blocking(canary)
    if blocking and "allow_blocking" not in request.keywords:
        pytest.fail("the event loop was blocked:\n" + "\n".join(blocking[:5]))


@pytest.fixture(autouse=True)
async def _fail_on_blocking(
    request: pytest.FixtureRequest, loop_block_collector: SlowCallbackCollector, monkeypatch: pytest.MonkeyPatch
) -> AsyncIterator[None]:
    """Every async test runs with the blocking checks (the browser tests' own loop: tests/e2e/conftest.py)."""
    async with blocking_checks(request, loop_block_collector, monkeypatch):
        yield


@pytest.fixture
def fleet_config() -> FleetConfig:
    return load_config(ROOT / "robots.yaml")


@dataclass
class RunningRelay:
    url: str
    ws_url: str
    relay: Relay
    runner: web.AppRunner


async def start_relay(config: FleetConfig, backend: str = "sim", options: Options | None = None) -> RunningRelay:
    app = create_app(config, options or Options(backend=backend))
    runner = await open_runner(app)
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    host, port = runner.addresses[0][:2]
    return RunningRelay(f"http://{host}:{port}", f"ws://{host}:{port}/ws", app[RELAY_KEY], runner)


@pytest.fixture
async def relay_server(fleet_config: FleetConfig) -> AsyncIterator[RunningRelay]:
    running = await start_relay(fleet_config)
    try:
        yield running
    finally:
        await running.runner.cleanup()


#: ROS domain ids that are safe on Linux: from 102 on, a participant's ports can fall in the ephemeral range that
#: port-0 sockets draw from. Domain 0, everyone's default, is left out.
_DOMAIN_RANGE = range(1, 102)


def _remove_orphaned_segments(session: pytest.Session) -> None:
    # Once, in the process that runs the workers: between the suite's two parts and around the whole.
    if not hasattr(session.config, "workerinput"):
        remove_orphaned_segments()


pytest_sessionstart = pytest_sessionfinish = _remove_orphaned_segments


@pytest.hookimpl(optionalhook=True)
def pytest_handlecrashitem(crashitem: str, report: pytest.TestReport, sched: Any) -> None:
    """A worker died under a test (pytest-xdist): the memory at that moment goes with the failure, and where the
    worker waited when the test ran into pytest-timeout's bound (tests/helpers/hang_report.py)."""
    report.sections.append(("memory when the worker died", memory_report()))
    stacks = quote(report.node.gateway.id)
    if stacks:
        report.sections.append((f"where the worker was {MARGIN_S:.0f} s before its test's timeout", stacks))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    marker = item.get_closest_marker("timeout")
    bound = float(marker.args[0] if marker and marker.args else item.config.getini("timeout") or 0)
    if bound <= MARGIN_S:
        yield
        return
    report = HangReport(
        stacks_file(os.environ.get("PYTEST_XDIST_WORKER", "main")), bound - MARGIN_S, lambda: list(_TIMED)
    )
    report.start()
    try:
        yield
    finally:
        report.cancel()


def pytest_configure(config: pytest.Config) -> None:
    # One random offset for the whole run, drawn before xdist starts its workers (they inherit the environment):
    # the workers' domains are disjoint, and a run beside another (a second checkout's) rarely meets its domains.
    os.environ.setdefault("XR_TEST_DOMAIN_OFFSET", str(random.randrange(len(_DOMAIN_RANGE))))
    if "XR_TEST_STACKS" not in os.environ:  # the controller's folder, inherited by the workers
        os.environ["XR_TEST_STACKS"] = tempfile.mkdtemp(prefix="xr-relay-stacks-")
        atexit.register(shutil.rmtree, os.environ["XR_TEST_STACKS"], True)


def _domains() -> Iterator[int]:
    """This process's ROS domains, endlessly: worker k of n takes every n-th id of the range from its k-th on."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    index = int(worker.removeprefix("gw")) if worker.removeprefix("gw").isdigit() else 0
    workers = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
    offset = int(os.environ.get("XR_TEST_DOMAIN_OFFSET", "0"))
    size = len(_DOMAIN_RANGE)
    own = [_DOMAIN_RANGE[(offset + k) % size] for k in range(index % size, size, workers)]
    return itertools.cycle(own)


#: Drawn on first use: at import this conftest runs before pytest_configure has chosen the run's offset, and a run
#: without workers then always began at domain 1 (two such runs at once shared it, and each other's robots).
_DOMAINS: Iterator[int] | None = None


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A ROS_DOMAIN_ID of this test's own, discovery on this machine only: runs never see each other."""
    global _DOMAINS
    if _DOMAINS is None:
        _DOMAINS = _domains()
    domain = next(_DOMAINS)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return domain


_SCRATCH: list[Path] = []


def _scratch() -> Path:
    """A directory of this process's own for what relay processes write by default (removed at exit)."""
    if not _SCRATCH:
        _SCRATCH.append(Path(tempfile.mkdtemp(prefix="xr-relay-tests-")))
        atexit.register(shutil.rmtree, _SCRATCH[0], True)
    return _SCRATCH[0]


_RELAY_PROCESSES = itertools.count()


def own_files(*args: str) -> tuple[str, ...]:
    """A relay command line's ARGS with an inspection database and an audit log of its own (in a temporary directory)
    unless ARGS name theirs, and no accounts unless ARGS name a users file: relays of tests that run in parallel do
    not share the checkout's defaults, and a relay's first start does not make an admin in the checkout."""
    n = next(_RELAY_PROCESSES)
    if "--database" not in args:
        args = (*args, "--database", str(_scratch() / f"inspection-{n}.sqlite"))
    if "--audit-log" not in args:
        args = (*args, "--audit-log", str(_scratch() / f"audit-{n}.jsonl"))
    if "--users" not in args:  # a lab bench (the operator token): a test of accounts names its users file
        args = (*args, "--no-accounts")
    return args


async def relay_process(
    *args: str, stderr: int | IO[bytes] = asyncio.subprocess.DEVNULL, port: int = 0, **options: Any
) -> tuple[asyncio.subprocess.Process, str]:
    """``python -m relay ARGS --port PORT`` (default 0: any free one) in a process of its own (this environment, so
    this test's ROS domain); returns it and the base URL it printed (``http://127.0.0.1:P``). ``options`` go to
    create_subprocess_exec. Its inspection database and audit log are its own unless ARGS name them (own_files)."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "relay", *own_files(*args), "--port", str(port), cwd=ROOT, stdout=asyncio.subprocess.PIPE,
        stderr=stderr, env=dict(os.environ), **options,
    )  # fmt: skip
    assert process.stdout is not None
    line = (await asyncio.wait_for(process.stdout.readline(), 60)).decode()
    if "open " not in line:
        process.kill()
        await process.wait()
        raise AssertionError(f"the relay did not start: it printed {line!r}")
    return process, line.split("open ")[1].split("/#")[0]


@pytest.fixture
async def router() -> AsyncIterator[Any]:
    """A Zenoh router on a free loopback port (tests/helpers/zenoh.py), for the tests of the zenoh backend."""
    from tests.helpers.zenoh import Router
    from tests.zenoh_robots import free_port

    r = Router(free_port())
    await r.open()
    try:
        yield r
    finally:
        await r.close()
