"""A situation-awareness probe's answers, pure: the relay's own answer (its truth at the moment it is asked) and the
choices the page offers, from the fleet's positions and modes and the scene's rooms."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Final

from ..wire.descriptions import RoomDescription
from .model import Probe

#: The modes a ``mode`` probe offers (relay/fleet/state.py).
MODES: Final = ("idle", "teleop", "navigating")


def truth(
    probe: Probe, positions: Mapping[str, tuple[float, float]], mode: str, rooms: Sequence[RoomDescription]
) -> str:
    """The right answer now: the room the robot is in, its ``mode``, or the robot nearest to it ("" when the relay
    does not know: no pose, no room there, no other robot)."""
    if probe.question == "mode":
        return mode
    here = positions.get(probe.robot)
    if here is None:
        return ""
    if probe.question == "room":
        for room in rooms:
            x0, y0, x1, y1 = room["bounds"]
            if x0 <= here[0] <= x1 and y0 <= here[1] <= y1:
                return room["name"]
        return ""
    others = {name: math.dist(here, p) for name, p in positions.items() if name != probe.robot}
    return min(others, key=others.__getitem__) if others else ""


def choices(probe: Probe, robots: Sequence[str], rooms: Sequence[RoomDescription]) -> list[str]:
    """What the page offers as answers."""
    if probe.question == "mode":
        return list(MODES)
    if probe.question == "room":
        return [room["name"] for room in rooms]
    return [name for name in robots if name != probe.robot]
