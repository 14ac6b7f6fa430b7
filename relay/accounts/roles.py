"""What each role may do: one table, asked by every check (relay/control/motion_gate.py, the inspection service).

- ``admin``: everything, and the accounts (``xr-relay users``);
- ``operator``: drive (teleop, goals, leases, cancel, playback), press and reset E-STOP, and inspection;
- ``inspector``: missions, targets, findings, schedules, alerts and reports; presses E-STOP (stopping is always
  safe) but never resets one, and drives nothing by hand;
- ``viewer``: watches.

The operator token of a lab bench (relay/net/access.py) admits as ``operator``, as before accounts existed.
"""

from __future__ import annotations

from typing import Final, Literal

from ..wire.messages import Role

Permission = Literal["drive", "stop", "reset", "inspect", "users"]

ROLES: Final[tuple[Role, ...]] = ("admin", "operator", "inspector", "viewer")

_MAY: Final[dict[Role, frozenset[Permission]]] = {
    "admin": frozenset({"drive", "stop", "reset", "inspect", "users"}),
    "operator": frozenset({"drive", "stop", "reset", "inspect"}),
    "inspector": frozenset({"stop", "inspect"}),
    "viewer": frozenset(),
}

#: How a refusal words what was missing.
WHAT: Final[dict[Permission, str]] = {
    "drive": "command robots",
    "stop": "press E-STOP",
    "reset": "reset an E-STOP",
    "inspect": "change missions, targets or findings",
    "users": "manage accounts",
}


def may(role: Role, permission: Permission) -> bool:
    return permission in _MAY[role]


def permissions(role: Role) -> frozenset[Permission]:
    """Everything ``role`` may do (the page's copy of this table is generated from it: tools/gen_protocol_js.py)."""
    return _MAY[role]


def role_of(text: str) -> Role:
    """A role from its name; ValueError naming the roles otherwise."""
    for role in ROLES:
        if role == text:
            return role
    raise ValueError(f"role {text[:40]!r} is none of {', '.join(ROLES)}")
