"""A client command declared once: a frozen dataclass whose fields carry their wire rule.

The same declaration parses a frame (:meth:`WireCommand.parse`), names the identifier a command arrived with, and
types the wire form the browser sends (:func:`wire_forms`, which tools/gen_protocol_js.py turns into JSDoc). A
feature adds a command by declaring it with :func:`command` and listing it in its table (relay/wire/table.py).

    @command("<robot>/cancel")
    @dataclass(frozen=True, slots=True)
    class Cancel(WireCommand):
        robot: str = from_identifier()
        id: RequestId = request()

A class with a rule across fields defines ``check(self, frame)`` (raise ProtocolError); one whose wire form has
variants lists them in ``FORMS`` (name -> identifiers, required keys, optional keys).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Final, Self, TypeVar

from ..errors import ProtocolError
from .fields import MISSING, ErrorCode, number, request_id, show, string

#: The placeholder of a robot-scoped identifier (``<robot>/goal_pose``).
ROBOT: Final = "<robot>"
_WIRE: Final = "wire"
C = TypeVar("C", bound="WireCommand")


@dataclass(frozen=True, slots=True)
class Frame:
    """What a field is read in: the frame's identifier, its robot (robot-scoped ones), and the fleet."""

    identifier: str
    robot: str | None
    robots: Collection[str]

    @property
    def suffix(self) -> str:
        """What follows the identifier's first slash (``pause`` of ``playback/pause``)."""
        return self.identifier.partition("/")[2]


@dataclass(frozen=True, slots=True)
class Rule:
    """How one field is read: its key on the wire ("" when it comes from the identifier), whether a frame must
    carry it, its type for the browser, and the reader."""

    key: str
    required: bool
    js: str
    read: Callable[[Mapping[str, Any], str, Frame], Any]


def _field(rule: Rule, default: Any = MISSING) -> Any:
    if default is MISSING:
        return dataclasses.field(metadata={_WIRE: rule})
    return dataclasses.field(default=default, metadata={_WIRE: rule})


def from_identifier() -> Any:
    """The robot of a ``<robot>/...`` identifier, or the action of a ``kind/<action>`` one."""

    def read(_: Mapping[str, Any], __: str, frame: Frame) -> Any:
        return frame.robot if frame.robot is not None else frame.suffix

    return _field(Rule("", True, "", read))


def request(*, required: bool = True) -> Any:
    """The request's ``id``, echoed in its ``ack`` or ``error``."""
    return _field(Rule("id", required, "RequestId", lambda obj, _, __: request_id(obj, required=required)))


def real(
    *,
    key: str = "",
    required: bool = True,
    low: float = -math.inf,
    high: float = math.inf,
    scale: float = 1.0,
    integer: bool = False,
    js: str = "number",
) -> Any:
    """A finite number within [low, high] (times ``scale``; truncated when ``integer``); ``js``: its type for the
    browser (``"number | null"`` where a client sends null for "none")."""

    def read(obj: Mapping[str, Any], name: str, frame: Frame) -> Any:
        value = number(obj, name, frame.identifier, required=required, low=low, high=high)
        if value is None:
            return None
        return int(value) if integer else value * scale

    return _field(Rule(key, required, js, read), MISSING if required else None)


def text(*, key: str = "", required: bool = True, pattern: re.Pattern[str] | None = None, says: str = "") -> Any:
    """A string of 1 to 64 characters; with ``pattern``, one it matches (``says`` what the pattern allows)."""

    def read(obj: Mapping[str, Any], name: str, frame: Frame) -> Any:
        value = string(obj, name, frame.identifier, required=required)
        if value is not None and pattern is not None and not pattern.match(value):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: field '{name}' must be {says}")
        return value

    return _field(Rule(key, required, "string", read), MISSING if required else None)


def choice(
    values: Sequence[str], *, default: str | None = None, code: str = ErrorCode.BAD_REQUEST, says: str = ""
) -> Any:
    """One of ``values`` (``default`` when absent; required when there is none); ``code`` and ``says`` for the
    refusal of another value (the error's code, and what follows the field's name)."""
    js = " | ".join(f"'{v}'" for v in values)

    def read(obj: Mapping[str, Any], name: str, frame: Frame) -> Any:
        value = obj.get(name, MISSING)
        if value is MISSING or value is None:
            if default is None:
                raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: missing field '{name}'")
            return default
        if value not in values:
            allowed = says or "must be " + " or ".join(f"'{v}'" for v in values)
            raise ProtocolError(code, f"{frame.identifier}: field '{name}' {allowed}, got {show(value)}")
        return value

    return _field(Rule("", default is None, js, read), MISSING if default is None else default)


def flag() -> Any:
    """true or false; false when absent."""

    def read(obj: Mapping[str, Any], name: str, frame: Frame) -> Any:
        value = obj.get(name, False)
        if not isinstance(value, bool):
            raise ProtocolError(ErrorCode.BAD_REQUEST, f"{frame.identifier}: field '{name}' must be true or false")
        return value

    return _field(Rule("", False, "boolean", read), False)


def custom(
    reader: Callable[[Any, str, str], Any], js: str, *, required: bool = False, key: str = "", default: Any = None
) -> Any:
    """A field with its own reader: ``reader(value or None, field name, identifier)`` returns the value or raises
    ProtocolError; ``js`` is its type for the browser. Absent and null both reach the reader as None."""

    def read(obj: Mapping[str, Any], name: str, frame: Frame) -> Any:
        return reader(obj.get(name), name, frame.identifier)

    return _field(Rule(key, required, js, read), MISSING if required else default)


def derived(read: Callable[[Mapping[str, Any], Frame], Any]) -> Any:
    """A value read from the whole frame by ``read(obj, frame)`` (its keys named in the command's ``FORMS``)."""
    return _field(Rule("", False, "", lambda obj, _, frame: read(obj, frame)))


Forms = Mapping[str, tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]]


class WireCommand:
    """The base of a declared command: parsing from its fields' rules and the identifier it arrived with."""

    __slots__ = ()
    IDENTIFIERS: ClassVar[tuple[str, ...]] = ()
    #: Variants of the wire form, for the browser's types: name -> (identifiers, required keys, optional keys).
    FORMS: ClassVar[Forms] = {}

    def check(self, frame: Frame) -> None:
        """A rule across fields (none by default): raise ProtocolError."""

    @classmethod
    def parse(cls, obj: Mapping[str, Any], frame: Frame) -> Self:
        values = {name: rule.read(obj, key, frame) for name, key, rule in rules(cls)}
        made = cls(**values)
        try:
            made.check(frame)
        except ProtocolError as exc:
            if exc.request_id is None:
                exc.request_id = values.get("id")
            raise
        return made

    @property
    def identifier(self) -> str:
        first = self.IDENTIFIERS[0]
        if first.startswith(ROBOT + "/"):
            return f"{getattr(self, 'robot')}/{first.partition('/')[2]}"  # noqa: B009 (declared by the subclass)
        if len(self.IDENTIFIERS) == 1:
            return first
        return f"{first.partition('/')[0]}/{getattr(self, 'action')}"  # noqa: B009 (declared by the subclass)


def rules(cls: type) -> list[tuple[str, str, Rule]]:
    """(attribute, wire key, rule) of each field of a declared command, in declaration order."""
    return [
        (f.name, f.metadata[_WIRE].key or f.name, f.metadata[_WIRE])
        for f in dataclasses.fields(cls)
        if _WIRE in f.metadata
    ]


def command(*identifiers: str) -> Callable[[type[C]], type[C]]:
    """Declare a dataclass a client command arriving as ``identifiers`` (``<robot>/kind`` for robot-scoped ones;
    several for a command whose ``action`` is the identifier's suffix, as ``playback/pause``)."""

    def declare(cls: type[C]) -> type[C]:
        missing = [f.name for f in dataclasses.fields(cls) if _WIRE not in f.metadata]  # type: ignore[arg-type]
        if missing or not identifiers:
            raise TypeError(f"{cls.__name__}: no identifier, or fields without a wire rule: {', '.join(missing)}")
        cls.IDENTIFIERS = identifiers
        return cls

    return declare


@dataclass(frozen=True, slots=True)
class WireForm:
    """One shape of a command's frame, for the browser's types: a JSDoc typedef named ``name``."""

    name: str
    identifiers: tuple[str, ...]
    fields: tuple[tuple[str, str, bool], ...]  # (key, JS type, required)


def wire_forms(cls: type[WireCommand], name: str) -> list[WireForm]:
    """The frames a declared command may arrive as: one form named ``name``, or its ``FORMS``."""
    declared: type[WireCommand] = cls
    wire = {key: rule for _, key, rule in rules(cls) if rule.js}  # not the robot or action of an identifier
    shown = tuple("" if i.startswith(ROBOT + "/") else i for i in declared.IDENTIFIERS)
    if not declared.FORMS:
        return [WireForm(name, shown, tuple((key, rule.js, rule.required) for key, rule in wire.items()))]
    forms = []
    for form, (identifiers, required, optional) in declared.FORMS.items():
        keys = [("id", True)] if "id" in wire else []
        keys += [(k, True) for k in required] + [(k, False) for k in optional]
        forms.append(WireForm(form, identifiers, tuple((*_typed(k, wire), req) for k, req in keys)))
    return forms


def _typed(key: str, wire: Mapping[str, Rule]) -> tuple[str, str]:
    """A FORMS key: a field's (its type from its rule), or ``"name: type"`` for a key a derived field reads."""
    name, _, js = key.partition(":")
    return (name, js.strip()) if js else (key, wire[key].js)
