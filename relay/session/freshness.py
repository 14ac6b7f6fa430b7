"""How old a stamped message is on the receiver's clock, without assuming the sender's clock agrees with it.

A teleop command that waited somewhere (in a frozen relay's socket buffer, behind a TCP retransmission, in a
stopped process) must not move a robot when it finally arrives: after a 3 s SIGSTOP the relay once published
twenty 1-3 s old ``cmd_vel`` after the deadman's zero. Receive times alone cannot see such waits (the frames are
read after the freeze, all at once), so senders stamp their messages on their own clock: the browser with
``performance.now()`` in ``cmd_vel.t``, the relay with its wall clock in the TwistStamped it gives the watchdog.

The two clocks need not agree. The delay of a message, ``received - sent``, is the clocks' offset plus its time
in transit; the smallest delay seen is the offset plus the quickest transit, and a message's age is how much
longer than that it took. The estimate of the smallest delay creeps up by ``CREEP`` seconds a second, so that a
sender whose clock was stepped back is believed again (after 50 s for a 1 s step) rather than never. The creep
is also the estimate's error after a silence: after a 3 s freeze, ages read 60 ms young, well inside a 0.5 s
deadman. A clock stepped forward only makes messages look fresher for a moment, which the deadman bounds.

Pure: times are passed in (seconds); tested in tests/test_freshness.py.
"""

from __future__ import annotations

#: Seconds per second the smallest-delay estimate rises by itself (see the module docstring).
CREEP = 0.02


class SenderClock:
    """Ages of one sender's stamped messages."""

    def __init__(self) -> None:
        self._smallest: float | None = None  # smallest delay seen, crept up to ``_at``
        self._at = 0.0

    def age(self, sent: float, received: float) -> float:
        """Seconds the message stamped ``sent`` (sender's clock) took beyond the quickest; 0 for the quickest."""
        delay = received - sent
        if self._smallest is None:
            self._smallest = delay
        else:
            self._smallest = min(self._smallest + CREEP * max(0.0, received - self._at), delay)
        self._at = received
        return delay - self._smallest
