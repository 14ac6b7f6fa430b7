"""Several relays, one fleet, over Zenoh's own primitives (relay/control/fleet_peer.py is the interface Control uses).

- **Estop**: a put on ``<fleet_key>/estop`` (reliable, blocking congestion control, express: never batched behind
  other traffic) carrying the sending relay's id, the robot (null: all) and the operator. Every relay subscribes;
  one that receives another's latches and stops its robots like an estop of its own.
- **Leases**: a liveliness token ``<fleet_key>/lease/<robot>/<relay-id>/<client>`` per lease this relay's operators
  hold, and a heartbeat ``<fleet_key>/heartbeat/<relay-id>`` every second (and at each change) listing them. Every
  relay subscribes to both (to the tokens with history, so a relay that starts late sees those already held). A
  lease counts while its token is there and its relay's heartbeats list it (relay/control/fleet_peer.py,
  ``PeerLeases``): Zenoh withdraws a token when its session ends (at once for a closed TCP connection; within the
  transport lease, 10 s by default, for a cut link), and a relay whose heartbeats stop (frozen, or a rogue session that
  only declared a token) loses its leases ``peer_lease_timeout`` after the last one. The robots themselves are stopped
  by their watchdog when the relay's robot heartbeat stops.
- **What others send** is checked field by field like a client's frame (relay/backends/zenoh_keys.py); a bad
  sample is refused whole and counted, and lines about other relays' samples are rate-limited
  (relay/logs/budget.py): 3000 malformed samples once wrote 3000 warnings.

Zenoh callbacks run on Zenoh's threads; what they learn reaches the loop through ``hop`` (the backend's crossing).
The table of remote leases is read on the loop and written on Zenoh's threads, under a lock.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import functools
import logging
import threading
import time
from collections.abc import Callable, Collection
from typing import Any

from ..control.fleet_peer import OnEstop, OnLease, PeerLeases, RemoteLease
from ..errors import BackendUnavailable
from ..logs.budget import BudgetedLog
from ..wire.fields import show
from .zenoh_keys import (
    PEER_NAME,
    FleetEstop,
    FleetHeartbeat,
    chunk,
    decode_estop,
    decode_heartbeat,
    estop_key,
    heartbeat_key,
    heartbeat_selector,
    lease_key,
    lease_selector,
    parse_lease_key,
)

logger = logging.getLogger(__name__)

#: Seconds between two heartbeats of this relay's leases.
HEARTBEAT_PERIOD = 1.0
#: Seconds a lease held through another relay lasts after its relay's last heartbeat (robots.yaml's
#: ``zenoh.peer_lease_timeout``): Zenoh's own transport lease, so that a cut link and a silent relay free a robot
#: alike.
PEER_LEASE_TIMEOUT = 10.0


class ZenohFleet:
    def __init__(
        self,
        fleet_key: str,
        relay_id: str | None,
        hop: Callable[[Callable[[], None]], None],
        robots: Collection[str],
        *,
        lease_timeout: float = PEER_LEASE_TIMEOUT,
        log: BudgetedLog | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        #: This relay's name among the others; without one configured, its Zenoh session id (set by ``open``).
        self.relay_id = chunk(relay_id) if relay_id else ""
        if self.relay_id and not PEER_NAME.fullmatch(self.relay_id):
            raise BackendUnavailable(
                f"--relay-id (zenoh.relay_id) is 1 to 64 letters, digits, _ . or -, got {show(self.relay_id)}"
            )
        self._key = fleet_key
        self._hop = hop
        self._robots = frozenset(robots)
        self._clock = clock
        self._zenoh: Any = None
        self._session: Any = None
        self._entities: list[Any] = []
        self._estop_pub: Any = None
        self._beat_pub: Any = None
        self._on_estop: OnEstop | None = None
        self._on_lease: OnLease | None = None
        self._lock = threading.Lock()
        self._leases = PeerLeases(self._robots, lease_timeout)
        self._log = log if log is not None else BudgetedLog(logger, "fleet: lines about other relays' samples")
        #: Samples of other relays refused, by kind; entries left out of full tables.
        self.refused = {"estop": 0, "heartbeat": 0, "lease": 0}
        self.left_out = 0
        #: This relay's leases (robot -> holder; the loop's) and their tokens (robot -> token; under _token_lock).
        self._held: dict[str, str] = {}
        self._tokens: dict[str, Any] = {}
        self._token_lock = threading.Lock()
        #: Declaring and withdrawing a token are calls that wait on Zenoh's runtime (the loop must never; a goal that
        #: took a lease once saw the loop held 1.26 s on a loaded machine): one thread does them, in order.
        self._token_worker = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="fleet-tokens")

    def open(self, zenoh: Any, session: Any) -> None:
        """Declare the estop and heartbeat publishers and subscribers and the lease tokens' subscriber on
        ``session`` (again after the backend re-opened it: the leases held here are declared anew)."""
        self._zenoh, self._session = zenoh, session
        if not self.relay_id:
            self.relay_id = chunk(str(session.zid()))
        self._estop_pub = session.declare_publisher(
            estop_key(self._key),
            congestion_control=zenoh.CongestionControl.BLOCK,
            priority=zenoh.Priority.REAL_TIME,
            express=True,
        )
        # A heartbeat lost is replaced by the next one: dropped under congestion, never blocking the loop.
        self._beat_pub = session.declare_publisher(
            heartbeat_key(self._key, self.relay_id), congestion_control=zenoh.CongestionControl.DROP
        )
        self._entities = [
            self._estop_pub,
            self._beat_pub,
            session.declare_subscriber(estop_key(self._key), self._on_estop_sample),
            session.declare_subscriber(heartbeat_selector(self._key), self._on_heartbeat),
            session.liveliness().declare_subscriber(lease_selector(self._key), self._on_token, history=True),
        ]
        with self._token_lock:
            self._tokens.clear()
        for robot, holder in dict(self._held).items():
            self._swap_token(robot, holder)
        self._beat()

    def attach(self, on_estop: OnEstop, on_lease: OnLease) -> None:
        self._on_estop, self._on_lease = on_estop, on_lease

    async def run(self) -> None:
        """Every second, on the loop: this relay's heartbeat (a frozen relay sends none, and loses its leases on the
        others), the others' leases that lapsed, and the summary of log lines left out."""
        while True:
            self._beat()
            self._announce(None)
            self._log.flush()
            await asyncio.sleep(HEARTBEAT_PERIOD)

    def health(self) -> dict[str, object]:
        with self._lock:
            relays = self._leases.relays(self._clock())
        return {
            "relays_heard": relays, "refused": dict(self.refused), "left_out": self.left_out,
            "log_lines_left_out": self._log.dropped,
        }  # fmt: skip

    # -- leases -----------------------------------------------------------------------------------

    def held_elsewhere(self, robot: str) -> RemoteLease | None:
        with self._lock:
            return self._leases.lease(robot, self._clock(), time.time())

    def lease_changed(self, robot: str, holder: str | None) -> None:
        """Loop: this relay's lease of ``robot`` changed hands (None: released). The heartbeat says so at once; the
        token follows on the token thread."""
        self._held.pop(robot, None)
        if holder is not None:
            self._held[robot] = holder
        self._token_worker.submit(self._swap_token, robot, holder)
        self._beat()

    def _swap_token(self, robot: str, holder: str | None) -> None:
        """Token thread (or the backend's worker in ``open``): withdraw ``robot``'s token, declare the holder's."""
        with self._token_lock:
            old = self._tokens.pop(robot, None)
            with contextlib.suppress(Exception):  # a session being closed took it with it
                if old is not None:
                    old.undeclare()
                session = self._session
                if holder is not None and session is not None:
                    key = lease_key(self._key, robot, self.relay_id, holder)
                    self._tokens[robot] = session.liveliness().declare_token(key)

    def _beat(self) -> None:
        publisher = self._beat_pub
        if publisher is not None:
            with contextlib.suppress(Exception):  # a session being re-opened: the next beat goes out
                publisher.put(FleetHeartbeat(self.relay_id, dict(self._held)).encode())

    def _on_token(self, sample: Any) -> None:
        """Zenoh thread: a lease token appeared or went away."""
        present = sample.kind != self._zenoh.SampleKind.DELETE
        try:
            robot, relay, client = parse_lease_key(self._key, str(sample.key_expr))
        except ValueError as exc:
            if present:  # its withdrawal was refused with it
                self._refuse("lease", exc)
            return
        if relay == self.relay_id:
            return
        with self._lock:
            if not self._leases.token(robot, relay, client, present):
                self.left_out += 1
                self._log.warning(
                    "fleet: %d lease tokens are known: one more, of relay %s, is left out",
                    self._leases.max_tokens,
                    relay,
                )
            self._announce([robot])

    def _on_heartbeat(self, sample: Any) -> None:
        """Zenoh thread: a relay's heartbeat (ours come back too, and are ignored)."""
        try:
            beat = decode_heartbeat(self._key, str(sample.key_expr), sample.payload.to_bytes())
        except ValueError as exc:
            self._refuse("heartbeat", exc)
            return
        if beat.relay == self.relay_id:
            return
        with self._lock:
            before = self._leases.listed(beat.relay)
            if not self._leases.heartbeat(beat.relay, beat.leases, self._clock()):
                self.left_out += 1
                self._log.warning("fleet: too many relays heard from: relay %s is left out", beat.relay)
            self._announce(before | beat.leases.keys())

    def _announce(self, robots: Collection[str] | None) -> None:
        """Tell Control of the robots whose holder through another relay changed (under the lock, or on the loop
        with it taken here: the changes reach the loop in the order they were found)."""
        if robots is None:
            with self._lock:
                self._announce_locked(None)
        else:
            self._announce_locked(robots)

    def _announce_locked(self, robots: Collection[str] | None) -> None:
        changes = self._leases.changes(self._clock(), robots)
        on_lease = self._on_lease
        for robot, holder in changes.items():
            self._log.info("fleet: %s is %s", robot, f"held by {holder}" if holder else "no longer held elsewhere")
            if on_lease is not None:
                self._hop(functools.partial(on_lease, robot, holder))

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
            self._refuse("estop", exc)
            return
        if estop.relay == self.relay_id:
            return
        if estop.robot is not None and estop.robot not in self._robots:
            self._log.warning(
                "fleet: an emergency stop from relay %s names %s, which this relay does not serve: ignored",
                estop.relay, estop.robot,
            )  # fmt: skip
            return
        self._log.warning(
            "fleet: EMERGENCY STOP of %s from relay %s (by %s)", estop.robot or "every robot", estop.relay, estop.by
        )
        on_estop = self._on_estop
        if on_estop is not None:
            by = f"{estop.by or 'an operator'} via relay {estop.relay}"
            self._hop(lambda: on_estop(estop.robot, by))

    def _refuse(self, kind: str, exc: ValueError) -> None:
        with self._lock:
            self.refused[kind] += 1
        self._log.warning("fleet: another relay's %s sample refused: %s", kind, exc)

    def close(self) -> None:
        """Undeclare everything (the session is closing); the leases held are remembered for ``open``."""
        with self._token_lock:
            tokens = list(self._tokens.values())
            self._tokens.clear()
        for entity in [*tokens, *self._entities]:
            with contextlib.suppress(Exception):  # a session already gone took them with it
                entity.undeclare()
        self._entities = []
        self._estop_pub = self._beat_pub = None
        with self._lock:
            self._leases.clear()
