"""The valve wheel on the wire (docs/protocol.md, ``valve``): where the simulated facility's valve is, how far it has
been turned, whether a gripper holds it and whether it is shut, for the twin to draw it turning.

A message of its own, global (the facility's, not a robot's), latest-value state; the sim backend reports it as a
:class:`relay.fleet.events.ValveEvent` when it changes (relay/sim/valve.py ``ValveWheel.report``).
"""

from __future__ import annotations

import dataclasses
from typing import Final, Literal, TypedDict, cast

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


#: Decimals on the wire: millimetres and milliradians, far finer than a wheel of 10 cm drawn in the twin.
_DECIMALS: Final = {"x": 3, "y": 3, "z": 3, "yaw": 4, "radius": 3, "angle": 3}


def valve_message(event: ValveEvent) -> ValveMessage:
    """The event's fields as the wire has them (the event's ``robot``, always empty, left out)."""
    fields = {f.name: getattr(event, f.name) for f in dataclasses.fields(event) if f.name != "robot"}
    rounded = {name: round(value, _DECIMALS[name]) if name in _DECIMALS else value for name, value in fields.items()}
    return cast(ValveMessage, {"identifier": "valve", **rounded})
