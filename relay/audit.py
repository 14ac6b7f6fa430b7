"""The audit log: every command the relay accepts or refuses, one JSON object per line.

Operators answer "who sent robot2 where, and when" from it. Each record is written with one ``write`` on a
file opened for appending, and handed to the kernel at once (no user-space buffer), so it survives the relay
being killed (SIGKILL) right after. When the file reaches ``max_bytes`` it is rotated: ``audit.jsonl``
becomes ``audit.jsonl.1``, ``.1`` becomes ``.2`` and so on, keeping ``backups`` old files.

A record (docs/security.md lists the fields):

    {"time": "2026-11-21T23:42:22.123456+00:00", "t": 1795304542.123456, "client": "c1-ab12cd",
     "role": "operator", "address": "127.0.0.1", "identifier": "robot2/goal_pose", "id": "g1",
     "values": {"x": 3.0, "y": 6.0, "yaw": null}, "outcome": "accepted", "code": null, "message": null}

``outcome`` is ``accepted`` or ``refused`` (then ``code`` and ``message`` say why, as the client was told).
The first record of each run is the relay's own (``client`` and ``role`` ``relay``, ``identifier`` ``relay/start``,
``outcome`` ``started``): it tells at once whether the log can be written. While it cannot, ``failure`` says why and
the relay refuses to move robots (``audit_unavailable``).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import orjson

from .errors import AuditLogUnavailable, ProtocolError
from .protocol import Command, Ping, RequestId, command_identifier

if TYPE_CHECKING:
    from .clients import Client

logger = logging.getLogger(__name__)


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
    ) -> None:
        now = dt.datetime.now(dt.UTC)
        line = orjson.dumps(
            {
                "time": now.isoformat(),
                "t": round(now.timestamp(), 6),
                "client": client,
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
            # keeps stopping robots, and refuses to move them while it cannot record (relay.commands).
            if self.failure is None:
                logger.error("audit log %s: %s; motion commands are refused until it works", self.path, exc)
            self.failure = f"the audit log {self.path} cannot be written: {exc.strerror or exc}"

    def _rotate(self) -> None:
        os.close(self._fd)
        for index in range(self.backups - 1, 0, -1):
            older = self.path.with_name(f"{self.path.name}.{index}")
            if older.exists():
                older.replace(self.path.with_name(f"{self.path.name}.{index + 1}"))
        if self.backups > 0:
            self.path.replace(self.path.with_name(f"{self.path.name}.1"))
        else:
            self.path.unlink()
        self._fd = self._open()

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class CommandAudit:
    """Records commands as their outcome is known; a relay without an audit log records nothing."""

    def __init__(self, log: AuditLog | None) -> None:
        self.log = log

    def command(self, client: Client, command: Command, error: ProtocolError | None) -> None:
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
        self.log.record(
            client=client.client_id,
            role=client.role,
            address=client.address,
            identifier=identifier,
            request_id=request_id,
            values=values,
            outcome="refused" if error else "accepted",
            code=error.code if error else None,
            message=error.message if error else None,
        )

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
