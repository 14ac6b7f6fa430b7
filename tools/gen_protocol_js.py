"""Write xr_client/src/protocol.js from the relay's wire schema, so the browser never retypes it.

The browser gets the protocol constants, the error codes, a JSDoc typedef of every message in both directions
(the server's from the TypedDicts of relay/wire/, relay/inspection/messages.py, relay/arm/wire.py and
relay/study/wire.py, named as there; the client's
from each command's one declaration, relay.session.protocol.COMMANDS, ``<Name>Command`` or its ``FORMS``), the unions
``ServerMessage`` and ``ClientMessage``, and the identifier helpers. Run after changing the schema:
``python tools/gen_protocol_js.py``; a test fails while the committed file differs from what this prints.
"""

from __future__ import annotations

import json
import sys
import types
import typing
from pathlib import Path
from typing import Any, Literal, NotRequired, Union, get_args, get_origin, get_type_hints, is_typeddict

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from relay.accounts import roles  # noqa: E402
from relay.arm import wire as arm_wire  # noqa: E402
from relay.control import safety  # noqa: E402
from relay.inspection import messages as inspection_messages  # noqa: E402
from relay.inspection import records  # noqa: E402
from relay.session import protocol  # noqa: E402
from relay.sim import valve_wire  # noqa: E402
from relay.station import messages  # noqa: E402
from relay.study import wire as study_wire  # noqa: E402
from relay.wire import descriptions, frames, viewer  # noqa: E402
from relay.wire import messages as station_messages  # noqa: E402
from relay.wire.declare import WireForm, wire_forms  # noqa: E402

TARGET = ROOT / "xr_client" / "src" / "protocol.js"

#: Type aliases that get a typedef of their own (Python name -> the alias object).
ALIASES: dict[str, Any] = {
    "RequestId": protocol.RequestId,
    "Role": protocol.Role,
    "Mode": protocol.Mode,
    "LeaseReason": messages.LeaseReason,
    "MissionState": records.MissionState,
    "FindingStatus": records.FindingStatus,
    "StepKind": records.StepKind,
}

# The identifier helpers, as the browser needs them: the same rules as relay/session/protocol.py's builders.
IDENTIFIER_HELPERS = """
const GLOBAL_IDENTIFIERS = new Set([...SERVER_GLOBAL_KINDS, ...CLIENT_GLOBAL_KINDS]);

/**
 * `<robot>/<kind>`: the identifier of a robot-scoped message (`robot1/pose`).
 * @param {string} robot
 * @param {string} kind
 * @returns {string}
 */
export function robotIdentifier(robot, kind) {
  return `${robot}/${kind}`;
}

/**
 * The identifier of a camera's binary frames (`robot1/camera/front`).
 * @param {string} robot
 * @param {string} camera
 * @returns {string}
 */
export function cameraIdentifier(robot, camera) {
  return robotIdentifier(robot, `camera/${camera}`);
}

/**
 * Split an identifier: a global one (`hello`, `playback/pause`) has no robot and is its own kind; a robot-scoped
 * one is `<robot>/<kind>`, where the kind may hold more slashes (`camera/front`).
 * @param {string} identifier
 * @returns {{robot: string | null, kind: string}}
 */
export function parseIdentifier(identifier) {
  const slash = identifier.indexOf('/');
  if (GLOBAL_IDENTIFIERS.has(identifier) || slash <= 0) return { robot: null, kind: identifier };
  return { robot: identifier.slice(0, slash), kind: identifier.slice(slash + 1) };
}
"""


def _typeddicts(module: types.ModuleType) -> list[type]:
    """The TypedDicts a module defines, in the order of its source."""
    found = [v for v in vars(module).values() if is_typeddict(v) and v.__module__ == module.__name__]
    source = Path(module.__file__ or "").read_text(encoding="utf-8")
    return sorted(found, key=lambda t: source.index(f"class {t.__name__}("))


def js_type(hint: Any, *, expand: bool = False) -> str:
    """A Python type hint as a JSDoc (TypeScript-flavoured) type; ``expand`` spells out a named alias itself."""
    for name, alias in ALIASES.items():
        if hint == alias and not expand:
            return name
    origin = get_origin(hint)
    if hint is type(None) or hint is None:
        return "null"
    if hint is Any:
        return "unknown"
    if hint is str:
        return "string"
    if hint is bool:
        return "boolean"
    if hint in (int, float):
        return "number"
    if is_typeddict(hint):
        return str(hint.__name__)
    if origin is Literal:
        return " | ".join(json.dumps(v).replace('"', "'") for v in get_args(hint))
    if origin in (Union, types.UnionType):
        return " | ".join(dict.fromkeys(js_type(a) for a in get_args(hint)))
    if origin is list or origin is tuple:
        (item, *_) = get_args(hint)
        inner = js_type(item)
        return f"({inner})[]" if "|" in inner else f"{inner}[]"
    if origin is dict:
        _, value = get_args(hint)
        return f"Object<string, {js_type(value)}>"
    if origin is NotRequired:
        return js_type(get_args(hint)[0])
    raise TypeError(f"no JavaScript type for {hint!r}")


def typedef(cls: type) -> str:
    hints = get_type_hints(cls, include_extras=True)
    fields = []
    for name, hint in hints.items():
        # With postponed annotations, __optional_keys__ cannot see NotRequired; the resolved hint can.
        mark = "?" if get_origin(hint) is NotRequired else ""
        fields.append(f"{name}{mark}: {js_type(hint)}")
    return f"/** @typedef {{{{{', '.join(fields)}}}}} {cls.__name__} */"


def command_typedef(form: WireForm) -> str:
    """A client command's wire form: its identifier (a string for robot-scoped ones) and its fields."""
    identifier = " | ".join(f"'{i}'" for i in form.identifiers) if all(form.identifiers) else "string"
    fields = [
        f"identifier: {identifier}",
        *(f"{key}{'' if required else '?'}: {js}" for key, js, required in form.fields),
    ]
    return f"/** @typedef {{{{{', '.join(fields)}}}}} {form.name} */"


def union(name: str, alias: Any, doc: str) -> str:
    members = " | ".join(t.__name__ for t in typing.get_args(alias))
    return f"/**\n * {doc}\n * @typedef {{{members}}} {name}\n */"


def render() -> str:
    codes = {name: getattr(protocol.ErrorCode, name) for name in dir(protocol.ErrorCode) if name.isupper()}
    codes.pop("ALL", None)
    values = {
        "PROTOCOL_VERSION": protocol.PROTOCOL_VERSION,
        "MAX_TEXT_BYTES": protocol.MAX_TEXT_BYTES,
        "MAX_STREAM_FPS": protocol.MAX_STREAM_FPS,
        "MAX_SCAN_POINTS": protocol.MAX_SCAN_POINTS,
        "GOAL_CLEARANCE": safety.GOAL_CLEARANCE,
        "FRAME_PREFIX_BYTES": protocol.FRAME_PREFIX.size,
        "ERROR_CODES": dict(sorted(codes.items())),
        "CLIENT_ROBOT_KINDS": list(protocol.CLIENT_ROBOT_KINDS),
        "CLIENT_GLOBAL_KINDS": list(protocol.CLIENT_GLOBAL_KINDS),
        "SERVER_ROBOT_KINDS": list(protocol.SERVER_ROBOT_KINDS),
        "SERVER_GLOBAL_KINDS": list(protocol.SERVER_GLOBAL_KINDS),
        # What each role may do (relay/accounts/roles.py): the page offers only what the relay would accept.
        "ROLE_PERMISSIONS": {role: sorted(roles.permissions(role)) for role in roles.ROLES},
    }
    lines = [
        "// @ts-check",
        "// Generated by tools/gen_protocol_js.py from relay/wire/, relay/session/protocol.py and relay/inspection: "
        "do not edit by hand.",
        "// The contract is docs/protocol.md.",
        "",
    ]
    for name, value in values.items():
        text = json.dumps(value)
        lines.append(
            f"export const {name} = " + (f"Object.freeze({text});" if isinstance(value, dict | list) else f"{text};")
        )
    lines += ["", "/** @typedef {" + " | ".join(f"'{c}'" for c in sorted(codes.values())) + "} ErrorCodeValue */"]
    lines += [f"/** @typedef {{{js_type(alias, expand=True)}}} {name} */" for name, alias in ALIASES.items()]
    lines += ["", "// Server to client"]
    for module in (
        descriptions, station_messages, frames, inspection_messages, arm_wire, study_wire, viewer, valve_wire
    ):  # fmt: skip
        lines += [typedef(t) for t in _typeddicts(module)]
    lines.append(union("ServerMessage", messages.ServerMessage, "Every text frame the relay sends."))
    lines += ["", "// Client to server"]
    forms = [form for cls in protocol.COMMANDS.commands for form in wire_forms(cls, f"{cls.__name__}Command")]
    lines += [command_typedef(form) for form in forms]
    members = " | ".join(form.name for form in forms)
    lines.append(f"/**\n * Every text frame a client may send.\n * @typedef {{{members}}} ClientMessage\n */")
    return "\n".join(lines) + "\n" + IDENTIFIER_HELPERS


def main() -> int:
    TARGET.write_text(render(), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
