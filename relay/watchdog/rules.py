"""The watchdog's rules, apart from ROS: what reaches a robot's ``cmd_vel``, from which source, and when it stops.

The watchdog runs on or next to the robot and is the only publisher of its ``cmd_vel`` (a twist_mux with a lock).
It takes two sources and the relay's word:

- **teleop**: the relay's TwistStamped, forwarded only while the relay's heartbeat is fresh and the command itself
  is fresh (its stamp, on the relay's clock, no older than ``timeout`` by ``relay.session.freshness``); a zero (a stop)
  is always forwarded. A relay stopped by SIGSTOP, starved of CPU or cut off stops nothing itself (a robot once turned
  for the 3 s the relay was stopped): its heartbeat stops, and so do its commands here.
- **autonomy**: the robot's own navigation output (Nav2's controller on ``cmd_vel_nav``), unstamped: forwarded only
  while no teleop arrived within ``timeout`` (teleop overrides it, a teleop zero included), the gate is ``drive``,
  and the relay's heartbeat is fresh, or ``on_relay_lost`` is ``continue``.
- **the gate**, the relay's word on a transient-local topic: ``drive`` lets autonomy through; ``hold`` blocks it
  (teleop still passes); ``estop`` latches: a zero at the base's command rate (20 Hz) and nothing forwarded from
  any source until the gate leaves ``estop``. The latch lives here, so it outlasts the relay that set it.

When the forwarded source goes quiet for ``timeout`` while the robot moves, the robot gets one zero; one, not a
stream, outside an estop: a stream would fight the source that takes over next. Cutting autonomy off (``hold``,
or the heartbeat lost under ``on_relay_lost: hold``) while it drives is a zero at once. Before the relay's first
word the gate is ``hold``: a watchdog that (re)starts lets no autonomy through until a relay says ``drive``.

Pure: times are passed in (seconds, the watchdog's own clock). Tested in tests/test_watchdog.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ..session.freshness import SenderClock

Gate = Literal["drive", "hold", "estop"]
GATES: tuple[Gate, ...] = ("drive", "hold", "estop")
Source = Literal["teleop", "autonomy"]
#: Seconds between the zeros of a latched estop: 20 Hz, the rate bases expect commands at (Nav2's controller's).
ESTOP_PERIOD = 0.05


@dataclass(frozen=True, slots=True)
class Verdict:
    forward: bool
    reason: str  # why a command was not forwarded ("" when it was)


class WatchdogRules:
    """One robot's watchdog."""

    def __init__(self, timeout: float, on_relay_lost: Literal["hold", "continue"] = "hold") -> None:
        self.timeout = timeout
        self.on_relay_lost = on_relay_lost
        self._gate: Gate = "hold"
        self._sender = SenderClock()
        self._heartbeat: float | None = None  # when the relay's last heartbeat arrived
        self._teleop: float | None = None  # when the last teleop command arrived
        self._last_command = 0.0  # when the last forwarded command arrived
        self._source: Source | None = None  # the source of the last forwarded motion while ``moving``
        self._zero_due = 0.0  # when the next estop zero is due
        self.moving = False  # the robot was last told a non-zero velocity

    @property
    def gate(self) -> Gate:
        return self._gate

    def heartbeat(self, now: float) -> None:
        self._heartbeat = now

    def relay_alive(self, now: float) -> bool:
        return self._heartbeat is not None and now - self._heartbeat <= self.timeout

    def teleop_active(self, now: float) -> bool:
        return self._teleop is not None and now - self._teleop <= self.timeout

    def set_gate(self, word: str, now: float) -> str | None:
        """The relay's word; the reason to publish a zero now, or None. ValueError (naming it) for another word,
        which changes nothing."""
        if word not in GATES:
            raise ValueError(f"a gate is one of {', '.join(GATES)}, got {word[:40]!r}")
        previous, self._gate = self._gate, word
        if word == previous:
            return None
        if word == "estop":
            self.moving = False
            self._zero_due = now + ESTOP_PERIOD
            return "estop latched"
        if word == "hold" and self.moving and self._source == "autonomy":
            self.moving = False
            return "the gate is hold: autonomy is blocked"
        return None  # leaving an estop: its zeros stop, and nothing moves the robot until a source does

    def command(self, linear: float, angular: float, stamp: float, now: float) -> Verdict:
        """Whether to forward teleop stamped ``stamp`` (relay's clock) arriving at ``now``."""
        age = self._sender.age(stamp, now)  # every command keeps the clock estimate current, forwarded or not
        if self._gate == "estop":
            return Verdict(False, "estop latched: nothing is forwarded until the relay resets it")
        self._teleop = now
        if linear == 0.0 and angular == 0.0:
            self._forwarded(now, None)
            return Verdict(True, "")
        if age > self.timeout:
            return Verdict(False, f"stale: {age:.2f} s old (timeout {self.timeout:g} s)")
        if not self.relay_alive(now):
            return Verdict(False, "no heartbeat from the relay")
        self._forwarded(now, "teleop")
        return Verdict(True, "")

    def autonomy(self, linear: float, angular: float, now: float) -> Verdict:
        """Whether to forward the robot's own navigation output arriving at ``now``."""
        if self._gate == "estop":
            return Verdict(False, "estop latched: nothing is forwarded until the relay resets it")
        if self.teleop_active(now):
            return Verdict(False, "teleop overrides autonomy")
        if self._gate == "hold":
            return Verdict(False, "the gate is hold")
        if self.on_relay_lost == "hold" and not self.relay_alive(now):
            return Verdict(False, "no heartbeat from the relay (on_relay_lost: hold)")
        self._forwarded(now, None if linear == 0.0 and angular == 0.0 else "autonomy")
        return Verdict(True, "")

    def _forwarded(self, now: float, source: Source | None) -> None:
        self._last_command = now
        self._source = source
        self.moving = source is not None

    def tick(self, now: float) -> str | None:
        """Called often (every 20 ms): the reason to publish a zero now, or None."""
        if self._gate == "estop":
            if now < self._zero_due:
                return None
            # Due times step by the period, so that a 20 ms tick still gives 20 Hz on average (intervals of 40 and
            # 60 ms); a tick later than a period starts afresh rather than catching up with a burst of zeros.
            late = now - self._zero_due > ESTOP_PERIOD
            self._zero_due = (now if late else self._zero_due) + ESTOP_PERIOD
            return "estop latched"
        if not self.moving:
            return None
        if now - self._last_command > self.timeout:
            reason = f"no {self._source} command for {now - self._last_command:.2f} s"
        elif self.relay_alive(now):
            return None
        elif self._source == "teleop":
            reason = "the relay's heartbeat stopped"
        elif self.on_relay_lost == "hold":
            reason = "the relay's heartbeat stopped (on_relay_lost: hold)"
        else:
            return None
        self.moving = False
        return reason
