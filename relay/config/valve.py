"""robots.yaml's ``sim.valve``: a valve wheel in the simulated facility that an arm's gripper turns (issue #32).

``{x, y, z, yaw, radius, hazard, fade}``: the wheel's centre in the map frame (metres), the way its face looks (its
axis, horizontal, at ``yaw`` radians), its rim's radius, the sensor field whose sources it shuts (those within
``relay.sim.valve.REACH`` of it: the leak it feeds), and how fast the leak's reading falls once it is shut (seconds
to a third, e^-1). Errors name the file, the line and the field like every other (relay.config).
"""

from __future__ import annotations

from yaml.nodes import Node

from .model import Valve
from .reader import _Reader

VALVE_FIELDS = ("x", "y", "z", "yaw", "radius", "hazard", "fade")


def valve(reader: _Reader, node: Node) -> Valve:
    path = "sim.valve"
    f = reader.mapping(node, path, VALVE_FIELDS, required=("x", "y", "z", "hazard"))

    def positive(n: Node, p: str) -> float:
        return reader.number(n, p, positive=True)

    return Valve(
        x=reader.number(f["x"], f"{path}.x"),
        y=reader.number(f["y"], f"{path}.y"),
        z=reader.number(f["z"], f"{path}.z", non_negative=True),
        yaw=reader.get(f, "yaw", path, reader.number, Valve.yaw),
        radius=reader.get(f, "radius", path, positive, Valve.radius),
        hazard=reader.string(f["hazard"], f"{path}.hazard", expected="a sensor field's name (sim.fields)"),
        fade=reader.get(f, "fade", path, positive, Valve.fade),
    )
