"""Other relays serving the same robots: the small interface :class:`~relay.control.control.Control` talks to when a
backend can reach them (the ``zenoh`` backend's :class:`~relay.backends.zenoh_fleet.ZenohFleet`); other backends
have none and nothing changes for them.

Estop and leases stay decided by each relay's own rules (relay/control/control.py, relay/control/leases.py); a peer only
carries them across: an estop made here latches every other relay, one made elsewhere latches this one; a lease held
through another relay refuses this relay's commands for that robot until it is released there, or that relay is
gone or falls silent (:class:`PeerLeases`). No consensus of our own: what two relays grant in the same instant both
hold (docs/zenoh.md).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from typing import Protocol

#: ``on_estop(robot or None for every robot, by)``, called on the event loop for an estop made on another relay.
OnEstop = Callable[[str | None, str | None], None]
#: ``on_lease(robot, holder)``: the holder through another relay changed (None: nobody there), on the loop.
OnLease = Callable[[str, str | None], None]


@dataclass(frozen=True, slots=True)
class RemoteLease:
    """A lease held through another relay, as seen at one instant."""

    robot: str
    relay: str
    client: str
    #: When it lapses unless its relay renews it (seconds since the epoch: the operator is told this time).
    until: float
    #: Seconds from the instant it was looked up to ``until``.
    remaining: float

    @property
    def holder(self) -> str:
        return f"{self.client} through relay {self.relay}"

    def lapse(self) -> str:
        """``until 14:02:07 UTC (in 9 s) unless relay B renews it``: what a refusal tells the operator."""
        at = time.strftime("%H:%M:%S", time.gmtime(self.until))
        return f"until {at} UTC (in {math.ceil(self.remaining)} s) unless relay {self.relay} renews it"


class FleetPeer(Protocol):
    #: This relay's name among the others (a Zenoh key chunk).
    relay_id: str

    def attach(self, on_estop: OnEstop, on_lease: OnLease) -> None:
        """Where estops and lease changes of other relays go (called once, by Control)."""

    def held_elsewhere(self, robot: str) -> RemoteLease | None:
        """The lease of ``robot`` held through another relay, or None."""

    def lease_changed(self, robot: str, holder: str | None) -> None:
        """This relay's lease of ``robot`` is now ``holder``'s (None: released): tell the others."""

    def estop(self, robot: str | None, by: str | None) -> None:
        """An estop was made here: latch and stop the robots on every other relay."""


class PeerLeases:
    """Which robots are held through other relays: the rule, with the time passed in (no I/O, no threads).

    Two things must say so: the relay's **token** for the lease (present while its session lives, withdrawn by
    Zenoh when it ends) and its **heartbeat**, which lists the leases it holds and lasts ``timeout`` seconds. A
    token alone holds nothing: a rogue session that declared one blocked even a forced take-over for as long as
    it lived (issue 28); now a relay that stops renewing its leases (killed, frozen, cut off, or never a relay)
    loses them ``timeout`` after its last heartbeat. Tables are bounded: what does not fit is left out (the caller
    counts it), and only this relay's robots are kept.
    """

    def __init__(
        self, robots: Collection[str], timeout: float, *, max_tokens: int = 1024, max_relays: int = 256
    ) -> None:
        self.robots = frozenset(robots)
        self.timeout = timeout
        self.max_tokens = max_tokens
        self.max_relays = max_relays
        #: robot -> {(relay, client)} of the tokens present.
        self._tokens: dict[str, set[tuple[str, str]]] = {}
        self._token_count = 0
        #: relay -> (when its last heartbeat came, the leases it listed: robot -> client).
        self._beats: dict[str, tuple[float, dict[str, str]]] = {}
        #: The holder last reported per robot (:meth:`changes`).
        self._reported: dict[str, str] = {}

    def token(self, robot: str, relay: str, client: str, present: bool) -> bool:
        """A token appeared (``present``) or went away; False when it did not fit and was left out."""
        if robot not in self.robots:
            return True
        held = self._tokens.get(robot)
        if not present:
            if held is not None and (relay, client) in held:
                held.discard((relay, client))
                self._token_count -= 1
                if not held:
                    del self._tokens[robot]
            return True
        if held is not None and (relay, client) in held:
            return True
        if self._token_count >= self.max_tokens:
            return False
        self._tokens.setdefault(robot, set()).add((relay, client))
        self._token_count += 1
        return True

    def heartbeat(self, relay: str, leases: Mapping[str, str], now: float) -> bool:
        """``relay`` holds ``leases`` (robot -> client) as of ``now``; False when too many relays are heard from."""
        if relay not in self._beats and len(self._beats) >= self.max_relays:
            self.forget_silent(now)
            if len(self._beats) >= self.max_relays:
                return False
        self._beats[relay] = (now, {robot: client for robot, client in leases.items() if robot in self.robots})
        return True

    def listed(self, relay: str) -> set[str]:
        """The robots of this relay that ``relay``'s last heartbeat listed."""
        beat = self._beats.get(relay)
        return set(beat[1]) if beat is not None else set()

    def forget_silent(self, now: float) -> None:
        """Drop the heartbeats that have lapsed (they hold nothing any more)."""
        for relay in [r for r, (seen, _) in self._beats.items() if now - seen >= self.timeout]:
            del self._beats[relay]

    def lease(self, robot: str, now: float, wall: float) -> RemoteLease | None:
        """The lease of ``robot`` held through another relay at ``now`` (``wall``: the same instant on the wall
        clock, for :attr:`RemoteLease.until`); of two (a race between relays), the one that lapses last."""
        best: tuple[float, str, str] | None = None
        for relay, client in self._tokens.get(robot, ()):
            beat = self._beats.get(relay)
            if beat is None or beat[1].get(robot) != client:
                continue
            lapses = beat[0] + self.timeout
            if now < lapses and (best is None or (lapses, relay, client) > best):
                best = (lapses, relay, client)
        if best is None:
            return None
        lapses, relay, client = best
        return RemoteLease(robot, relay, client, until=wall + (lapses - now), remaining=lapses - now)

    def changes(self, now: float, robots: Collection[str] | None = None) -> dict[str, str | None]:
        """Robots (of ``robots``, else all) whose holder through another relay is not the one last reported (None:
        nobody now); they are reported as changed once."""
        changed: dict[str, str | None] = {}
        for robot in self.robots if robots is None else robots:
            lease = self.lease(robot, now, 0.0)
            holder = lease.holder if lease is not None else None
            if self._reported.get(robot) != holder:
                changed[robot] = holder
                if holder is None:
                    del self._reported[robot]
                else:
                    self._reported[robot] = holder
        return changed

    def relays(self, now: float) -> int:
        """Relays heard from within ``timeout``."""
        return sum(1 for seen, _ in self._beats.values() if now - seen < self.timeout)

    def clear(self) -> None:
        """The session closed: nothing of the others is known any more (a new session hears it all again)."""
        self._tokens.clear()
        self._token_count = 0
        self._beats.clear()
