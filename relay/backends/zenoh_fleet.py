"""Several relays, one fleet, over Zenoh's own primitives (relay/fleet_peer.py is the interface Control uses).

- **Estop**: a put on ``<fleet_key>/estop`` (reliable, blocking congestion control, express: never batched behind
  other traffic) carrying the sending relay's id, the robot (null: all) and the operator. Every relay subscribes;
  one that receives another's latches and stops its robots like an estop of its own.
- **Leases**: a liveliness token ``<fleet_key>/lease/<robot>/<relay-id>/<client>`` per lease this relay's operators
  hold. Every relay subscribes to the tokens (with history, so a relay that starts late sees those already held).
  Zenoh withdraws a token when its session ends, cleanly or not: a relay that dies frees its robots once its
  router notices (at once for a closed TCP connection; within the transport lease, 10 s by default, for a cut
  link), and the robots themselves are stopped by their watchdog when its heartbeat stops.

Zenoh callbacks run on Zenoh's threads; what they learn reaches the loop through ``hop`` (the backend's crossing).
The table of remote leases is read on the loop and written on Zenoh's threads, under a lock.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable
from typing import Any

from ..fleet_peer import OnEstop, OnLease
from .zenoh_keys import (
    FleetEstop,
    chunk,
    decode_estop,
    estop_key,
    lease_key,
    lease_selector,
    parse_lease_key,
)

logger = logging.getLogger(__name__)


class ZenohFleet:
    def __init__(self, fleet_key: str, relay_id: str | None, hop: Callable[[Callable[[], None]], None]) -> None:
        #: This relay's name among the others; without one configured, its Zenoh session id (set by ``open``).
        self.relay_id = chunk(relay_id) if relay_id else ""
        self._key = fleet_key
        self._hop = hop
        self._zenoh: Any = None
        self._session: Any = None
        self._entities: list[Any] = []
        self._estop_pub: Any = None
        self._on_estop: OnEstop | None = None
        self._on_lease: OnLease | None = None
        self._lock = threading.Lock()
        #: Tokens of other relays: key -> (robot, relay, client).
        self._remote: dict[str, tuple[str, str, str]] = {}
        #: This relay's leases (robot -> holder) and their tokens (robot -> token).
        self._held: dict[str, str] = {}
        self._tokens: dict[str, Any] = {}

    def open(self, zenoh: Any, session: Any) -> None:
        """Declare the estop publisher and subscriber and the lease tokens' subscriber on ``session`` (again after
        the backend re-opened it: the leases held here are declared anew)."""
        self._zenoh, self._session = zenoh, session
        if not self.relay_id:
            self.relay_id = chunk(str(session.zid()))
        self._estop_pub = session.declare_publisher(
            estop_key(self._key),
            congestion_control=zenoh.CongestionControl.BLOCK,
            priority=zenoh.Priority.REAL_TIME,
            express=True,
        )
        self._entities = [
            self._estop_pub,
            session.declare_subscriber(estop_key(self._key), self._on_estop_sample),
            session.liveliness().declare_subscriber(lease_selector(self._key), self._on_token, history=True),
        ]
        self._tokens.clear()
        for robot, holder in self._held.items():
            self._declare(robot, holder)

    def attach(self, on_estop: OnEstop, on_lease: OnLease) -> None:
        self._on_estop, self._on_lease = on_estop, on_lease

    # -- leases -----------------------------------------------------------------------------------

    def held_elsewhere(self, robot: str) -> str | None:
        name = chunk(robot)
        with self._lock:
            for r, relay, client in self._remote.values():
                if r == name and relay != self.relay_id:
                    return f"{client} through relay {relay}"
        return None

    def lease_changed(self, robot: str, holder: str | None) -> None:
        old = self._tokens.pop(robot, None)
        if old is not None:
            old.undeclare()
        self._held.pop(robot, None)
        if holder is not None:
            self._held[robot] = holder
            self._declare(robot, holder)

    def _declare(self, robot: str, holder: str) -> None:
        if self._session is not None:
            key = lease_key(self._key, robot, self.relay_id, holder)
            self._tokens[robot] = self._session.liveliness().declare_token(key)

    def _on_token(self, sample: Any) -> None:
        """Zenoh thread: a lease token appeared or went away."""
        key = str(sample.key_expr)
        parsed = parse_lease_key(self._key, key)
        if parsed is None:
            logger.warning("fleet: a liveliness token %s is not a lease (<robot>/<relay>/<client>): ignored", key)
            return
        robot, relay, client = parsed
        if relay == self.relay_id:
            return
        gone = sample.kind == self._zenoh.SampleKind.DELETE
        with self._lock:
            if gone:
                self._remote.pop(key, None)
            else:
                self._remote[key] = parsed
        logger.info(
            "fleet: lease of %s %s %s through relay %s", robot, "released by" if gone else "held by", client, relay
        )
        holder = self.held_elsewhere(robot)
        on_lease = self._on_lease
        if on_lease is not None:
            self._hop(lambda: on_lease(robot, holder))

    # -- estop ------------------------------------------------------------------------------------

    def estop(self, robot: str | None, by: str | None) -> None:
        """Sent from a thread of its own: the put blocks while the link is congested (it must not be dropped),
        and this relay's own robots must not wait for it (Control stops them right after this returns)."""
        publisher = self._estop_pub
        if publisher is None:
            raise RuntimeError("the Zenoh session is not open: the other relays cannot be told")
        payload = FleetEstop(self.relay_id, robot, by).encode()

        def send() -> None:
            try:
                publisher.put(payload)
            except Exception:
                logger.exception("fleet: the emergency stop could not be sent to the other relays")

        threading.Thread(target=send, name="fleet-estop", daemon=True).start()

    def _on_estop_sample(self, sample: Any) -> None:
        """Zenoh thread: an estop from some relay (our own come back too, and are ignored)."""
        try:
            estop = decode_estop(sample.payload.to_bytes())
        except ValueError as exc:
            logger.warning("fleet: a sample on %s is not an estop: %s", sample.key_expr, exc)
            return
        if estop.relay == self.relay_id:
            return
        logger.warning(
            "fleet: EMERGENCY STOP of %s from relay %s (by %s)", estop.robot or "every robot", estop.relay, estop.by
        )
        on_estop = self._on_estop
        if on_estop is not None:
            by = f"{estop.by or 'an operator'} via relay {estop.relay}"
            self._hop(lambda: on_estop(estop.robot, by))

    def close(self) -> None:
        """Undeclare everything (the session is closing); the leases held are remembered for ``open``."""
        for entity in [*self._tokens.values(), *self._entities]:
            with contextlib.suppress(Exception):  # a session already gone took them with it
                entity.undeclare()
        self._tokens.clear()
        self._entities = []
        self._estop_pub = None
        with self._lock:
            self._remote.clear()
