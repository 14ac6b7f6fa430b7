"""Other relays serving the same robots: the small interface :class:`~relay.control.Control` talks to when a
backend can reach them (the ``zenoh`` backend's :class:`~relay.backends.zenoh_fleet.ZenohFleet`); other backends
have none and nothing changes for them.

Estop and leases stay decided by each relay's own rules (relay/control.py, relay/leases.py); a peer only carries
them across: an estop made here latches every other relay, one made elsewhere latches this one; a lease held
through another relay refuses this relay's commands for that robot until it is released there, or that relay is
gone. No consensus of our own: what two relays grant in the same instant both hold (docs/zenoh.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

#: ``on_estop(robot or None for every robot, by)``, called on the event loop for an estop made on another relay.
OnEstop = Callable[[str | None, str | None], None]
#: ``on_lease(robot, holder)``: the holder through another relay changed (None: nobody there), on the loop.
OnLease = Callable[[str, str | None], None]


class FleetPeer(Protocol):
    #: This relay's name among the others (a Zenoh key chunk).
    relay_id: str

    def attach(self, on_estop: OnEstop, on_lease: OnLease) -> None:
        """Where estops and lease changes of other relays go (called once, by Control)."""

    def held_elsewhere(self, robot: str) -> str | None:
        """Who holds ``robot``'s lease through another relay (``client via relay R``), or None."""

    def lease_changed(self, robot: str, holder: str | None) -> None:
        """This relay's lease of ``robot`` is now ``holder``'s (None: released): tell the others."""

    def estop(self, robot: str | None, by: str | None) -> None:
        """An estop was made here: latch and stop the robots on every other relay."""
