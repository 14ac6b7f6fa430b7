"""The valve wheel on the wire (docs/protocol.md, ``valve``): where the simulated facility's valve is, how far it has
been turned, whether a gripper holds it and whether it is shut, for the twin to draw it turning.

A message of its own, global (the facility's, not a robot's), latest-value state; the sim backend reports it as a
:class:`relay.fleet.events.ValveEvent` when it changes (relay/sim/valve.py ``ValveWheel.report``).
"""

from __future__ import annotations

from typing import Literal, TypedDict

from ..fleet.events import ValveEvent


class ValveMessage(TypedDict):
    identifier: Literal["valve"]
    #: The wheel's centre in the map frame (m), its axis (the way its face looks, rad about +z) and its rim (m).
    x: float
    y: float
    z: float
    yaw: float
    radius: float
    #: How far it has been turned (rad, either sign; right-handed about its axis); a quarter turn shuts it.
    angle: float
    held: bool
    shut: bool


def valve_message(event: ValveEvent) -> ValveMessage:
    # Millimetres and milliradians: far finer than a wheel of 10 cm drawn in the twin.
    return {
        "identifier": "valve",
        "x": round(event.x, 3),
        "y": round(event.y, 3),
        "z": round(event.z, 3),
        "yaw": round(event.yaw, 4),
        "radius": round(event.radius, 3),
        "angle": round(event.angle, 3),
        "held": event.held,
        "shut": event.shut,
    }
