"""Every exception the relay raises on purpose.

    RelayError
    ├── ConfigError          robots.yaml (or another config file) is invalid: file, line, field, expectation
    ├── ProtocolError        a client frame is malformed or names something unknown; becomes an `error` reply
    │   └── CommandRejected  a well-formed command that the relay or the backend refuses (bounds, no path, ...)
    ├── BackendUnavailable   the chosen backend cannot start here (e.g. rclpy is not installed)
    └── AuditLogUnavailable  the audit log cannot be opened at start-up (the path is a file's parent, ...)

A `ProtocolError` never closes a connection: the server turns it into an `error` message carrying the
command's `id` (when one could be read) and keeps reading.
"""

from __future__ import annotations


class RelayError(Exception):
    """Base class of the relay's own exceptions."""


class ConfigError(RelayError):
    """A configuration file failed validation.

    ``str(err)`` reads ``robots.yaml:14: robots[1].limits.linear: expected a positive number, got "fast"``.
    """

    def __init__(self, file: str, line: int | None, field: str, message: str) -> None:
        self.file = file
        self.line = line
        self.field = field
        self.message = message
        where = f"{file}:{line}" if line is not None else file
        super().__init__(f"{where}: {field}: {message}" if field else f"{where}: {message}")


class ProtocolError(RelayError):
    """A client message that gets an ``error`` reply with ``code`` and a human-readable ``message``."""

    def __init__(self, code: str, message: str, request_id: str | int | None = None) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.request_id = request_id
        self.identifier: str | None = None  # the offending message's identifier, when it had one


class CommandRejected(ProtocolError):
    """A valid command that cannot be carried out (goal out of bounds, no path, no such camera...)."""


class AuditLogUnavailable(RelayError):
    """``--audit-log`` names a file the relay cannot open; the message names it and why."""


class BackendUnavailable(RelayError):
    """The backend cannot run on this machine; the message says how to fix it."""


class RecordingError(RelayError):
    """The session's recording could not start (relay/replay/recorder.py): the message names the file and why."""
