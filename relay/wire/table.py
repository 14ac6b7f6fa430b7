"""The commands a relay accepts, as one table: a frame's identifier picks its declaration, which parses it.

Built once from every declared command (the station's and each feature's, relay/session/protocol.py), so adding a
command is adding its declaration to a list; nothing here knows any command.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from typing import Any, Final

from ..errors import ProtocolError
from .declare import ROBOT, Frame, WireCommand
from .fields import MISSING, ErrorCode, show
from .json_frame import decode_json, peek_request_id

#: Longest part of an unparseable frame's identifier kept on its error (for the audit record).
MAX_SHOWN_IDENTIFIER: Final = 80


class CommandTable:
    """Parse a client's text frame into the command its identifier declares."""

    def __init__(self, commands: Iterable[type[WireCommand]]) -> None:
        self.commands = tuple(commands)
        self._global: dict[str, type[WireCommand]] = {}
        self._robot: dict[str, type[WireCommand]] = {}
        for cls in self.commands:
            for identifier in cls.IDENTIFIERS:
                robot, _, kind = identifier.partition("/")
                table, key = (self._robot, kind) if robot == ROBOT else (self._global, identifier)
                if key in table:
                    raise ValueError(f"{identifier} is declared twice: {table[key].__name__} and {cls.__name__}")
                table[key] = cls

    @property
    def robot_kinds(self) -> tuple[str, ...]:
        """Robot-scoped kinds a client may send (``<robot>/<kind>``)."""
        return tuple(self._robot)

    @property
    def global_kinds(self) -> tuple[str, ...]:
        """Global identifiers a client may send."""
        return tuple(self._global)

    def parse(self, data: str | bytes, robots: Collection[str]) -> WireCommand:
        """Validate one client text frame and return its command.

        ``robots`` are the configured robot names. Raises :class:`ProtocolError` carrying the message's ``id``
        when it could be read; the caller replies with ``error`` and keeps the connection open.
        """
        obj = decode_json(data)
        try:
            return self._parse_object(obj, robots)
        except ProtocolError as exc:
            if exc.request_id is None:
                exc.request_id = peek_request_id(obj)
            identifier = obj.get("identifier")
            exc.identifier = identifier[:MAX_SHOWN_IDENTIFIER] if isinstance(identifier, str) else None
            raise

    def _parse_object(self, obj: dict[str, Any], robots: Collection[str]) -> WireCommand:
        identifier = obj.get("identifier", MISSING)
        if identifier is MISSING:
            raise ProtocolError(ErrorCode.BAD_REQUEST, "message has no 'identifier' field")
        if not isinstance(identifier, str):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"'identifier' must be a string, got {show(identifier)}")
        declared = self._global.get(identifier)
        if declared is not None:
            return declared.parse(obj, Frame(identifier, None, robots))
        robot, sep, kind = identifier.partition("/")
        declared = self._robot.get(kind) if sep else None
        if declared is None:
            raise ProtocolError(
                ErrorCode.UNKNOWN_IDENTIFIER,
                f"unknown identifier {show(identifier)}; expected one of "
                + ", ".join([*self._global, *(f"<robot>/{k}" for k in self._robot)]),
            )
        if robot not in robots:
            raise ProtocolError(
                ErrorCode.UNKNOWN_ROBOT,
                # Both are the client's own text: shown clipped, so an error (and its audit record) stays short.
                f"{show(identifier)}: unknown robot {show(robot)}; the fleet is " + ", ".join(sorted(robots)),
            )
        return declared.parse(obj, Frame(identifier, robot, robots))
