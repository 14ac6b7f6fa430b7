"""The audit log: every command the relay accepts or refuses, one JSON object per line.

Operators answer "who sent robot2 where, and when" from it. Each record is written with one ``write`` on a
file opened for appending, and handed to the kernel at once (no user-space buffer), so it survives the relay
being killed (SIGKILL) right after. When the file reaches ``max_bytes`` it is rotated: ``audit.jsonl``
becomes ``audit.jsonl.1``, ``.1`` becomes ``.2`` and so on, keeping ``backups`` old files, and more while they
hold records of the last ``KEEP_SECONDS`` (an hour): rotation never drops a record younger than that.

**The budget.** So that an hour fits in bounded space, what a client can make the relay write is bounded:
records of refused frames, and every record of a viewer, are written at most ``QUIET_RATE`` a second per client
(bursts of twice that); the rest are counted into the next record's message ("N more ... not recorded"). An
operator's accepted commands are all recorded: at most ``--max-message-rate`` (60) a second, ~250 bytes each
for cmd_vel, so an operator driving flat out writes at most ~54 MB an hour (20 Hz teleop: ~18 MB), and a
viewer or a client sending garbage at most ~4 MB an hour (records clipped to under 700 characters). With the defaults
(10 MB files, 5 kept) the disk holds about 60 MB, more during an hour in which more was written.

A record (docs/security.md lists the fields):

    {"time": "2026-11-21T23:42:22.123456+00:00", "t": 1795304542.123456, "client": "c1-ab12cd",
     "name": "Ana", "role": "operator", "address": "127.0.0.1", "identifier": "robot2/goal_pose", "id": "g1",
     "values": {"x": 3.0, "y": 6.0, "yaw": null}, "outcome": "accepted", "code": null, "message": null}

``name``, only in the records of a client that gave one (``name``), is that name: who acknowledged an alert, who sent
a goal. A signed-in client's records (relay/accounts) carry ``user`` instead: its account, the person, not a name
anyone could type.
``outcome`` is ``accepted`` or ``refused`` (then ``code`` and ``message`` say why, as the client was told: its
first 120 characters).
The first record of each run is the relay's own (``client`` and ``role`` ``relay``, ``identifier`` ``relay/start``,
``outcome`` ``started``): it tells at once whether the log can be written. While it cannot, ``failure`` says why and
the relay refuses to move robots (``audit_unavailable``).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import logging
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import orjson

from ..errors import AuditLogUnavailable, ProtocolError
from ..session.protocol import Command, RequestId, command_identifier
from ..session.ratelimit import TokenBucket
from ..wire.commands import Ping

if TYPE_CHECKING:
    from ..session.clients import Client

logger = logging.getLogger(__name__)

#: Seconds of records that rotation never drops, however many files that takes.
KEEP_SECONDS = 3600.0
#: Records per second and client for refused frames and for viewers (bursts of twice that); the rest are counted.
QUIET_RATE = 2.0


class AuditLog:
    def __init__(self, path: str | os.PathLike[str], max_bytes: int = 10 * 1024 * 1024, backups: int = 5) -> None:
        self.path = Path(path)
        self.max_bytes = max_bytes
        self.backups = backups
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fd = self._open()
        except OSError as exc:
            raise AuditLogUnavailable(
                f"--audit-log {self.path}: cannot open it for appending: {exc.strerror or exc}"
            ) from None
        self.records = 0
        #: Why the last record could not be written (None: it was). The relay then refuses motion commands.
        self.failure: str | None = None

    def _open(self) -> int:
        return os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o640)

    def record(
        self,
        *,
        client: str,
        role: str,
        address: str | None,
        identifier: str | None,
        request_id: str | int | None,
        values: dict[str, Any] | None,
        outcome: str,
        code: str | None = None,
        message: str | None = None,
        name: str | None = None,
        user: str | None = None,
    ) -> None:
        now = dt.datetime.now(dt.UTC)
        # A signed-in client's name is its account's: the record says ``user`` alone.
        named = {"user": user} if user is not None else {"name": name} if name is not None else {}
        line = orjson.dumps(
            {
                "time": now.isoformat(),
                "t": round(now.timestamp(), 6),
                "client": client,
                **named,
                "role": role,
                "address": address,
                "identifier": identifier,
                "id": request_id,
                "values": values,
                "outcome": outcome,
                "code": code,
                "message": message,
            },
            option=orjson.OPT_APPEND_NEWLINE,
        )
        try:
            os.write(self._fd, line)
            self.records += 1
            self.failure = None
            if os.fstat(self._fd).st_size >= self.max_bytes:
                self._rotate()
        except OSError as exc:
            # The audit trail must not take the relay (and the robots' safety paths) down with it: the relay
            # keeps stopping robots, and refuses to move them while it cannot record (relay.session.commands).
            if self.failure is None:
                logger.error("audit log %s: %s; motion commands are refused until it works", self.path, exc)
            self.failure = f"the audit log {self.path} cannot be written: {exc.strerror or exc}"

    def _backup(self, index: int) -> Path:
        return self.path.with_name(f"{self.path.name}.{index}")

    def _rotate(self) -> None:
        os.close(self._fd)
        last = 0
        while self._backup(last + 1).exists():
            last += 1
        for index in range(last, 0, -1):
            self._backup(index).replace(self._backup(index + 1))
        self.path.replace(self._backup(1))
        # Beyond ``backups``, a file goes only when its newest record (its last write) is over an hour old.
        cutoff = time.time() - KEEP_SECONDS
        kept = 0
        for index in range(last + 1, self.backups, -1):
            old = self._backup(index)
            if old.stat().st_mtime < cutoff:
                old.unlink()
            else:
                kept += 1
        if kept:
            logger.warning(
                "audit log %s: keeping %d files beyond --audit-log's %d backups: they hold records of the last hour",
                self.path, kept, self.backups,
            )  # fmt: skip
        self._fd = self._open()

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class CommandAudit:
    """Records commands as their outcome is known; a relay without an audit log records nothing."""

    def __init__(
        self,
        log: AuditLog | None,
        clock: Callable[[], float] = time.monotonic,
        outcomes: Callable[[Command, ProtocolError | None], None] = lambda command, error: None,
    ) -> None:
        """``outcomes``: told every command's outcome too, logged or not (a study's task counts them,
        relay.study.service)."""
        self.log = log
        self._clock = clock
        self._outcomes = outcomes
        self._quiet: dict[str, tuple[TokenBucket, int]] = {}  # client id -> (allowance, records not written)

    def command(self, client: Client, command: Command, error: ProtocolError | None) -> None:
        self._outcomes(command, error)
        if self.log is None or isinstance(command, Ping):
            return  # pings are keep-alives, not commands
        values = {k: v for k, v in dataclasses.asdict(command).items() if k not in ("robot", "id", "sent")}
        self.frame(client, command_identifier(command), getattr(command, "id", None), values, error)

    def frame(
        self,
        client: Client,
        identifier: str | None,
        request_id: RequestId | None,
        values: dict[str, object] | None,
        error: ProtocolError | None,
    ) -> None:
        """One client frame, also one that could not be parsed (``identifier`` and ``values`` None then)."""
        if self.log is None:
            return
        message = fit(error.message, MAX_MESSAGE) if error else None  # clipped before the note, which must be read
        if error is not None or client.role == "viewer":
            # Refusals and viewers' records are budgeted per client (module docstring): a flood cannot rotate
            # the operators' records away, and what was not written is counted in the next record.
            now = self._clock()
            allowance, skipped = self._quiet.get(client.client_id) or (TokenBucket.full(QUIET_RATE, now), 0)
            if not allowance.take(now):
                self._quiet[client.client_id] = (allowance, skipped + 1)
                return
            self._quiet[client.client_id] = (allowance, 0)
            if skipped:
                note = f"{skipped} more refused or viewer records of this client not written since the last"
                message = f"{message} ({note})" if message else note
        self.log.record(
            client=client.client_id,
            role=client.role,
            address=client.address,
            identifier=identifier,
            request_id=fit(request_id, MAX_ID) if isinstance(request_id, str) else request_id,
            values=_clipped(values),
            outcome="refused" if error else "accepted",
            code=error.code if error else None,
            message=message,
            name=client.name,
            user=client.user,
        )

    def forget(self, client_id: str) -> None:
        self._quiet.pop(client_id, None)

    @property
    def failure(self) -> str | None:
        """Why commands cannot be recorded now (None: they can, or there is no audit log)."""
        return None if self.log is None else self.log.failure

    def started(self, address: str) -> None:
        """The first record: the relay started. It also tells at once whether the log can be written."""
        if self.log is not None:
            self.log.record(
                client="relay",
                role="relay",
                address=address,
                identifier="relay/start",
                request_id=None,
                values=None,
                outcome="started",
            )

    def close(self) -> None:
        if self.log is not None:
            self.log.close()


#: A record's values past this many characters of JSON are kept as their first characters (a 1000-character note, a
#: mission's 200 steps), and so are a refusal's message (before the count of records not written, ~80) and a
#: request's id: with the fixed fields (~230, and a client's name of up to 40 characters, ~50 more), a record stays
#: under 700 characters, as the budget above counts, whatever a hostile client puts in them.
MAX_VALUES = 160
MAX_MESSAGE = 120
MAX_ID = 48


def fit(text: str, limit: int) -> str:
    """The longest start of ``text`` whose JSON string form is at most ``limit`` characters between its quotes.

    Quotes, backslashes and control characters grow when escaped (a control character to six): hostile values clipped
    to 300 characters before escaping made 500, and records of 700.
    """
    if len(text) <= limit and len(orjson.dumps(text)) - 2 <= limit:
        return text
    low, high = 0, min(len(text), limit)
    while low < high:  # halving: at most 9 encodings of a few hundred characters
        middle = (low + high + 1) // 2
        if len(orjson.dumps(text[:middle]).decode()) - 2 <= limit:
            low = middle
        else:
            high = middle - 1
    return text[:low]


def _clipped(values: dict[str, object] | None) -> dict[str, object] | None:
    if values is None:
        return None
    text = orjson.dumps(values, default=repr).decode()
    return values if len(text) <= MAX_VALUES else {"clipped": fit(text, MAX_VALUES)}
