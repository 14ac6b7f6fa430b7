"""ROS topics on one Zenoh session: publishers that send what rmw_zenoh sends, subscribers that check each sample.

Keys are rmw_zenoh's (``<domain>/<topic>/<type>/<hash>``) or zenoh-bridge-ros2dds's (``<topic>``):
relay/backends/zenoh_keys.py has the layout. A subscriber takes ``<domain>/<topic>/*/*`` (any type and hash) and
checks the type per sample: a sample of another type, and a handler's failure, get one warning naming the key
(:class:`KeyWarnings`), never an exception into Zenoh's thread.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import itertools
import time
from collections.abc import Callable
from typing import Any

from ..logs.budget import BudgetedLog
from ..wire.fields import show
from .cdr_encode import CommandEncoder
from .zenoh_keys import GID_SIZE, Attachment, key_type, show_key, topic_key, topic_selector
from .zenoh_session import ZenohSettings

#: A query's answer, on Zenoh's thread: the reply's payload, or None and the error reply's text.
Reply = Callable[[bytes | None, str | None], None]
#: Keys remembered as warned about at most (a sender can make up new keys without end).
MAX_WARNED_KEYS = 1000


class ZenohPublisher:
    """A Zenoh publisher that sends what rmw_zenoh sends: the CDR bytes, and its attachment (sequence number,
    source timestamp, a GID of its own) unless the robots are behind zenoh-bridge-ros2dds."""

    def __init__(self, zenoh: Any, session: Any, key: str, attach: bool, *, latched: bool = False) -> None:
        self.key = key
        if latched:
            # The watchdog's gate: transient local as rmw_zenoh makes it (a cache of the last word, which a watchdog
            # that starts later asks for), and never dropped: like the fleet's estop, it waits for a congested link.
            # Sequence numbers (a client session has no timestamps) and a sporadic heartbeat let a subscriber that
            # missed the last word recover it from the cache.
            ext = importlib.import_module("zenoh.ext")
            self._publisher = ext.declare_advanced_publisher(
                session, key, cache=ext.CacheConfig(max_samples=1), publisher_detection=True,
                sample_miss_detection=ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=1.0),
                priority=zenoh.Priority.REAL_TIME, express=True, congestion_control=zenoh.CongestionControl.BLOCK,
            )  # fmt: skip
        else:
            # Commands go ahead of bulk data (express: not batched; high priority: their own queue), and are dropped
            # rather than block when the link is congested: a blocked put would stall the event loop, and with it
            # the deadman and the estop; a dropped command is what the robot's watchdog is for.
            self._publisher = session.declare_publisher(
                key, priority=zenoh.Priority.INTERACTIVE_HIGH, express=True,
                congestion_control=zenoh.CongestionControl.DROP,
            )  # fmt: skip
        self._attach = attach
        self._sequence = 0
        # rmw_zenoh hashes the entity's liveliness key into the GID; any 16 bytes unique to this publisher do.
        self._gid = hashlib.blake2b(f"{session.zid()}/{key}".encode(), digest_size=GID_SIZE).digest()

    def put(self, payload: bytes) -> None:
        self._sequence += 1
        attachment = Attachment(self._sequence, time.time_ns(), self._gid).encode() if self._attach else None
        self._publisher.put(payload, attachment=attachment)

    def matched(self) -> bool | None:
        """Whether a subscriber of this key is known to the session (None when Zenoh cannot tell)."""
        try:
            return bool(self._publisher.matching_status.matching)
        except Exception:  # an advanced publisher, a closed session
            return None

    def undeclare(self) -> None:
        with contextlib.suppress(Exception):  # the session may already be closed
            self._publisher.undeclare()


class KeyWarnings:
    """One warning per key about what arrived on it (a wrong type, an undecodable body), not one per sample, and
    those lines within the log budget (a sender can make up new keys)."""

    def __init__(self, log: BudgetedLog) -> None:
        self._log = log
        self._warned: set[str] = set()

    def __call__(self, key: str, message: str) -> None:
        if key not in self._warned and len(self._warned) < MAX_WARNED_KEYS:
            self._warned.add(key)
            self._log.warning("zenoh: %s", message)


class ZenohTopics:
    """Publishers and subscribers of ROS topics on ``session``, on the keys ``settings`` says."""

    def __init__(
        self, zenoh: Any, session: Any, settings: ZenohSettings, encode: CommandEncoder, warn_once: KeyWarnings
    ) -> None:
        self._zenoh = zenoh
        self._session = session
        self._settings = settings
        self._encode = encode
        self._warn_once = warn_once
        self._queries = itertools.count(1)
        # A query carries rmw_zenoh's attachment as a client's request does; any 16 bytes unique to this session do.
        self._gid = hashlib.blake2b(f"{session.zid()}/queries".encode(), digest_size=GID_SIZE).digest()

    @property
    def encoder(self) -> CommandEncoder:
        """What encodes the messages sent on these topics (and the types' hashes in their keys)."""
        return self._encode

    def publisher(self, topic: str, type_name: str, *, latched: bool = False) -> ZenohPublisher:
        s = self._settings
        key = topic_key(s.keys, s.domain, topic, type_name, self._encode.type_hash(type_name))
        return ZenohPublisher(self._zenoh, self._session, key, attach=s.keys == "rmw_zenoh", latched=latched)

    def subscribe(
        self, what: str, topic: str, type_name: str, handle: Callable[[bytes], None], *, history: bool = False
    ) -> Any:
        """A subscriber of ``topic`` whose samples of ``type_name`` go to ``handle`` (on Zenoh's thread); samples of
        another type, and a handler's failure, get one warning naming the key. ``history``: a transient-local
        topic (the map, a robot description), whose publisher's cache a late subscriber asks (zenoh-ext)."""
        s = self._settings
        selector = topic_selector(s.keys, s.domain, topic)

        def on_sample(sample: Any) -> None:
            key = str(sample.key_expr)
            sent = key_type(s.keys, key)
            if sent is not None and sent != type_name:
                self._warn_once(
                    key, f"{what}: a sample on {show_key(key)} is a {show(sent)}, not the {type_name} expected: ignored"
                )
                return
            try:
                handle(sample.payload.to_bytes())
            except Exception as exc:  # never into Zenoh's thread: one line, and the next sample is read
                self._warn_once(key, f"{what}: a sample on {show_key(key)} could not be read: {show(repr(exc))}")

        if history:
            ext = importlib.import_module("zenoh.ext")
            return ext.declare_advanced_subscriber(
                self._session, selector, on_sample, history=ext.HistoryConfig(detect_late_publishers=True)
            )
        return self._session.declare_subscriber(selector, on_sample)

    def query(self, service: str, payload: bytes, on_reply: Reply, timeout: float) -> None:
        """Ask ``service`` (a ROS service, or an action's ``_action/...``) now with a request's CDR bytes: each
        reply's payload goes to ``on_reply(payload, None)``, an error reply's text to ``on_reply(None, text)``, on
        Zenoh's thread. Returns at once."""
        s = self._settings
        attach = s.keys == "rmw_zenoh"
        attachment = Attachment(next(self._queries), time.time_ns(), self._gid).encode() if attach else None

        def reply(answer: Any) -> None:
            if answer.ok is None:
                on_reply(None, show(answer.err.payload.to_bytes()[:200].decode("utf-8", "replace")))
            else:
                on_reply(answer.ok.payload.to_bytes(), None)

        selector = topic_selector(s.keys, s.domain, service)
        self._session.get(selector, reply, payload=payload, attachment=attachment, timeout=timeout)
