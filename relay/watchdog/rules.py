"""The watchdog's rules, apart from ROS: what to forward to a robot's ``cmd_vel`` and when to stop it.

The relay's deadman stops a robot whose operator goes quiet, but only while the relay runs: a relay stopped by
SIGSTOP, starved of CPU or cut off by the network stops nothing (a robot once turned for the 3 s the relay was
stopped). The watchdog runs on or next to the robot and owns its last word:

- a command is forwarded only while the relay's heartbeat is fresh and the command itself is fresh (its stamp,
  on the relay's clock, no older than ``timeout`` by ``relay.freshness``);
- a zero command (a stop) is always forwarded;
- when commands or the heartbeat stop for ``timeout`` while the robot was last told to move, it gets one zero.

One zero, not a stream of them: a robot following a navigation goal gets its ``cmd_vel`` from the planner, which
a watchdog repeating zeros would fight. Pure: times are passed in (seconds, the watchdog's own wall clock).
Tested in tests/test_watchdog.py.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..freshness import SenderClock


@dataclass(frozen=True, slots=True)
class Verdict:
    forward: bool
    reason: str  # why a command was not forwarded ("" when it was)


class WatchdogRules:
    """One robot's watchdog."""

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self._sender = SenderClock()
        self._heartbeat: float | None = None  # when the relay's last heartbeat arrived
        self._last_command = 0.0  # when the last forwarded command arrived
        self.moving = False  # the robot was last told a non-zero velocity

    def heartbeat(self, now: float) -> None:
        self._heartbeat = now

    def relay_alive(self, now: float) -> bool:
        return self._heartbeat is not None and now - self._heartbeat <= self.timeout

    def command(self, linear: float, angular: float, stamp: float, now: float) -> Verdict:
        """Whether to forward a command stamped ``stamp`` (relay's clock) arriving at ``now``."""
        age = self._sender.age(stamp, now)
        if linear == 0.0 and angular == 0.0:
            self.moving = False
            self._last_command = now
            return Verdict(True, "")
        if age > self.timeout:
            return Verdict(False, f"stale: {age:.2f} s old (timeout {self.timeout:g} s)")
        if not self.relay_alive(now):
            return Verdict(False, "no heartbeat from the relay")
        self.moving = True
        self._last_command = now
        return Verdict(True, "")

    def tick(self, now: float) -> str | None:
        """Called often (every 20 ms): the reason to publish a zero now, or None."""
        if not self.moving:
            return None
        if now - self._last_command > self.timeout:
            reason = f"no command for {now - self._last_command:.2f} s"
        elif not self.relay_alive(now):
            reason = "the relay's heartbeat stopped"
        else:
            return None
        self.moving = False
        return reason
