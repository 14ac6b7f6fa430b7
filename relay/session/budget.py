"""How many snapshots each client may have the relay take: per role, per client, and in total.

A snapshot costs the relay real CPU (the sim renders 480x480 fisheye images by ray casting; a ROS camera's frame
is converted and JPEG-encoded), and viewers may ask for them. Without a budget, viewers could keep every core busy
and delay what operators do. The budget:

- per client: ``IN_FLIGHT[role]`` snapshots at once, and (viewers) one started every ``INTERVAL[role]`` seconds;
- in total: ``TOTAL`` at once, of which viewers together may hold ``TOTAL - OPERATOR_RESERVE``: an operator's
  snapshot always finds a slot that viewers cannot take.

A refused snapshot gets ``error`` ``busy`` at once, naming the limit. Streams need no budget of their own: a
camera is rendered and encoded once for every client, at most at its configured ``rate`` (relay.media.streams).
Pure: time is passed in; tested in tests/test_budget.py.
"""

from __future__ import annotations

from .protocol import Role

# Every role that works with the robots (relay/accounts/roles.py) is budgeted as an operator; a viewer watches.
IN_FLIGHT: dict[Role, int] = {"admin": 2, "operator": 2, "inspector": 2, "viewer": 1}
# An operator may ask for several cameras at once.
INTERVAL: dict[Role, float] = {"admin": 0.0, "operator": 0.0, "inspector": 0.0, "viewer": 1.0}
ARTICLE: dict[Role, str] = {"admin": "an", "operator": "an", "inspector": "an", "viewer": "a"}
TOTAL = 4
OPERATOR_RESERVE = 2


class SnapshotBudget:
    def __init__(self) -> None:
        self._in_flight: dict[str, int] = {}  # client id -> snapshots running
        self._viewers = 0  # snapshots running for viewers
        self._last: dict[str, float] = {}  # client id -> when its last snapshot started

    @property
    def total(self) -> int:
        return sum(self._in_flight.values())

    def take(self, client_id: str, role: Role, now: float) -> str | None:
        """Start a snapshot for the client, or say why not."""
        mine = self._in_flight.get(client_id, 0)
        if mine >= IN_FLIGHT[role]:
            allowed = f"{ARTICLE[role]} {role} may have {IN_FLIGHT[role]}"
            return f"{mine} snapshot(s) of this client already in progress ({allowed})"
        since = now - self._last.get(client_id, -1e18)
        if since < INTERVAL[role]:
            return f"{ARTICLE[role]} {role} may start one snapshot every {INTERVAL[role]:g} s"
        if self.total >= TOTAL:
            return f"the relay is taking {TOTAL} snapshots already"
        if role == "viewer" and self._viewers >= TOTAL - OPERATOR_RESERVE:
            return f"viewers hold {self._viewers} snapshots already; the rest is kept for operators"
        self._in_flight[client_id] = mine + 1
        self._viewers += role == "viewer"
        self._last[client_id] = now
        return None

    def done(self, client_id: str, role: Role) -> None:
        left = self._in_flight.get(client_id, 0) - 1
        if left > 0:
            self._in_flight[client_id] = left
        else:
            self._in_flight.pop(client_id, None)
        self._viewers -= role == "viewer"

    def forget(self, client_id: str) -> None:
        """The client left (its running snapshots were cancelled and have called ``done``)."""
        self._last.pop(client_id, None)
