"""The event loop's stalls, measured all the time, and what they mean for the age of a client's frame.

A beat is scheduled every ``PERIOD``; how late each one runs is the loop's lag at that moment. Every callback that
holds the loop (a parse, a database call, a starved process, a SIGSTOP) shows up as a late beat. ``/healthz`` and
``/metrics`` report the p99 and the worst lag of the last ``WINDOW`` beats and the worst since start.

**Dating a frame.** A motion command that waited in the relay's socket buffer while the relay was frozen must not
be replayed (a robot once turned 0.3-0.4 rad on 9-14 stale unstamped commands after a 3 s SIGSTOP). The kernel
does not tell asyncio when bytes arrived, but the beat does tell when the loop last ran: bytes read after a stall
may have arrived at any moment of it, so they are dated to its start (:meth:`LoopLag.arrival`). The beat may also
run first: a SIGSTOP that lands after the loop's ``select`` returned and before its callbacks (on a loaded machine
the loop's thread spends its time there, waiting for a CPU) resumes with the late beat, and the reads after it saw a
loop that had just run (60 of 60 stale commands were carried out). So the late beat tells its listeners
(:meth:`LoopLag.on_stall`): a connection whose socket holds unread bytes then (:func:`unread_bytes`, the kernel's
count) dates them to the stall's start; bytes that arrive after the beat are read as fresh. Per connection,
:class:`ArrivalDates` carries that date from the read to the frames it brought. Conservative by design: a frame
sent during the last instants of a freeze is dropped too, and the deadman had stopped the robot anyway.

:class:`LagStats` and :class:`ArrivalDates` are pure (times passed in); :class:`LoopLag` runs them on the loop.
"""

from __future__ import annotations

import asyncio
import collections
import fcntl
import math
import struct
import termios
from collections.abc import Callable

#: Seconds between beats: the resolution of the lag figures, for a cost of ~100 callbacks a second.
PERIOD = 0.01
#: A beat this much later than due means the loop stalled: bytes read then are dated to the stall's start.
#: 50 ms: well above a busy loop's ordinary lateness (a few ms here), well below the deadman's 0.5 s.
STALL = 0.05
#: How many recent beats the p99 and the recent worst are taken over (~10 s at PERIOD).
WINDOW = 1000


class LagStats:
    """The lateness of the recent beats: p99 and worst, and the worst since start."""

    def __init__(self, window: int = WINDOW) -> None:
        self._recent: collections.deque[float] = collections.deque(maxlen=window)
        self.worst_ever = 0.0
        self.beats = 0

    def add(self, lateness: float) -> None:
        lateness = max(0.0, lateness)
        self._recent.append(lateness)
        self.worst_ever = max(self.worst_ever, lateness)
        self.beats += 1

    def p99(self) -> float:
        if not self._recent:
            return 0.0
        ordered = sorted(self._recent)
        return ordered[min(len(ordered) - 1, math.ceil(0.99 * len(ordered)) - 1)]

    def worst(self) -> float:
        return max(self._recent, default=0.0)

    def report(self) -> dict[str, float]:
        """Milliseconds, for /healthz."""
        return {
            "p99_ms": round(self.p99() * 1000, 1),
            "worst_ms": round(self.worst() * 1000, 1),
            "worst_ever_ms": round(self.worst_ever * 1000, 1),
        }


class LoopLag:
    """Beats on the loop; ``clock`` is the loop's (monotonic seconds, as the relay's ``clock``)."""

    def __init__(self, clock: Callable[[], float], period: float = PERIOD, stall: float = STALL) -> None:
        self.clock, self.period, self.stall = clock, period, stall
        self.stats = LagStats()
        self.last_beat: float | None = None
        self._listeners: set[Callable[[float], None]] = set()  # told a stall's start by the beat that sees it
        self._due = 0.0
        self._handle: asyncio.TimerHandle | None = None

    def start(self) -> None:
        self.last_beat = self.clock()
        self._schedule()

    def stop(self) -> None:
        if self._handle is not None:
            self._handle.cancel()
            self._handle = None

    def _schedule(self) -> None:
        self._due = self.clock() + self.period
        self._handle = asyncio.get_running_loop().call_later(self.period, self._beat)

    def _beat(self) -> None:
        self.beat(self.clock(), self._due)
        self._schedule()

    def beat(self, now: float, due: float) -> None:
        """A beat due at ``due`` ran at ``now`` (the loop's part is ``_beat``); a stall is told to the listeners."""
        self.stats.add(now - due)
        start, self.last_beat = self.last_beat, now
        if now - due > self.stall and start is not None:
            for listener in tuple(self._listeners):
                listener(start)

    def on_stall(self, listener: Callable[[float], None]) -> Callable[[], None]:
        """Call ``listener(start)`` at each stall the beat sees, with when the loop last ran; returns its removal."""
        self._listeners.add(listener)
        return lambda: self._listeners.discard(listener)

    def arrival(self, now: float) -> float:
        """When bytes read at ``now`` arrived at the latest that can be known: ``now``, or when the loop last ran
        if it has stalled since (a beat overdue by more than ``stall``)."""
        last = self.last_beat
        if last is None or now - last <= self.period + self.stall:
            return now
        return last


class ArrivalDates:
    """One connection's frames dated by the reads that brought them (pure; the server feeds it).

    ``read(arrival)`` is called for every read from the socket, ``frame()`` for every frame taken from the
    connection, in order. A frame is dated to the earliest read not yet attributed, else to the date of the frame
    before it: frames are never dated later than the read that brought them, only earlier (more are dropped as
    stale, none is replayed).
    """

    def __init__(self, now: float) -> None:
        self._current = now
        self._pending: float | None = None

    def read(self, arrival: float) -> None:
        self._pending = arrival if self._pending is None else min(self._pending, arrival)

    def frame(self) -> float:
        if self._pending is not None:
            self._current, self._pending = self._pending, None
        return self._current


class DatedReads(asyncio.Protocol):
    """A connection's protocol, seen through: each read is reported (``on_read``) before the protocol parses it.

    asyncio hands a protocol its bytes without saying when they arrived; this stands between the transport and
    the protocol it had (aiohttp's, after the WebSocket upgrade) so that every read is dated where it happens.
    """

    def __init__(self, inner: asyncio.BaseProtocol, on_read: Callable[[], None]) -> None:
        self._inner, self._on_read = inner, on_read

    def data_received(self, data: bytes) -> None:
        self._on_read()
        self._inner.data_received(data)  # type: ignore[attr-defined]

    def eof_received(self) -> bool | None:
        return self._inner.eof_received()  # type: ignore[attr-defined, no-any-return]

    def connection_lost(self, exc: Exception | None) -> None:
        self._inner.connection_lost(exc)

    def pause_writing(self) -> None:
        self._inner.pause_writing()

    def resume_writing(self) -> None:
        self._inner.resume_writing()


def unread_bytes(transport: asyncio.BaseTransport) -> bool:
    """Whether the kernel holds bytes of this connection the loop has not read (FIONREAD); True when it cannot say."""
    sock = transport.get_extra_info("socket")
    if sock is None:
        return True
    try:
        count: int = struct.unpack("i", fcntl.ioctl(sock.fileno(), termios.FIONREAD, b"\0\0\0\0"))[0]
        return count > 0
    except (OSError, ValueError):
        return True


def date_reads(transport: asyncio.BaseTransport | None, on_read: Callable[[], None]) -> bool:
    """Put :class:`DatedReads` in front of ``transport``'s protocol; False when the transport cannot say."""
    if transport is None or not isinstance(transport, asyncio.Transport):
        return False
    inner = transport.get_protocol()
    if isinstance(inner, DatedReads):
        return True
    transport.set_protocol(DatedReads(inner, on_read))
    return True
