"""Targets: where they come from (the facility's hazards, a targets file, the operator) and how a robot looks at one.

- ``facility_targets``: the demo's hazards become its targets, one per kind and room (the three hot panels of the
  power room are one target, "Panels"), at the mean of their sources.
- ``load_targets``: a YAML file ``targets: [{id, name, kind, x, y, facing}]`` (``facing`` in degrees, optional);
  every error names the file, the line and the field.
- ``standoff``: the pose a robot inspects a target from: ``STANDOFF`` metres away, facing it, on a free cell with
  a clear line of sight; with a ``facing`` the robot looks along it, otherwise the side nearest the robot.

Pure; tested in tests/test_missions.py.
"""

from __future__ import annotations

import math
from pathlib import Path

import yaml
from yaml.nodes import Node

from ..config.reader import _Reader
from ..errors import ConfigError
from ..fleet.occupancy import OccupancyGrid
from ..twin.facility import Facility
from .records import TARGET_ID as TARGET_ID
from .records import Target

#: Metres between a robot's centre and the target it inspects; the alternatives are tried when that is blocked.
STANDOFF = 1.0
STANDOFF_ALTERNATIVES = (1.0, 1.3, 0.8, 1.6)
#: A robot's clearance to walls at its standoff pose (m): its radius and a margin.
CLEARANCE = 0.35

#: What the facility's hazard kinds are, as targets of an inspection.
HAZARD_TARGETS = {"gas": ("spill", "Spill"), "temperature": ("panels", "Panels"), "humidity": ("leak", "Leak")}


def facility_targets(facility: Facility) -> list[Target]:
    """One target per hazard kind and room (sources of one kind in one room are one thing to inspect)."""
    groups: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for hazard in facility.hazards:
        inside = (r.name for r in facility.rooms if r.min_x <= hazard.x <= r.max_x and r.min_y <= hazard.y <= r.max_y)
        groups.setdefault((hazard.kind, next(inside, "")), []).append((hazard.x, hazard.y))
    targets: list[Target] = []
    for (kind, room), points in groups.items():
        base, title = HAZARD_TARGETS.get(kind, (kind, kind.capitalize()))
        ident = base if not any(t.id == base for t in targets) else f"{base}-{room}"
        x = sum(p[0] for p in points) / len(points)
        y = sum(p[1] for p in points) / len(points)
        targets.append(Target(ident, title, kind, round(x, 3), round(y, 3)))
    return targets


def load_targets(path: str | Path) -> list[Target]:
    """Targets from a YAML file; raises ConfigError naming the file, line and field."""
    source = Path(path)
    reader = _Reader(str(source))
    try:
        root = yaml.compose(source.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(str(source), None, "", f"cannot read the file: {exc.strerror or exc}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ConfigError(str(source), None, "", f"not YAML: {exc}") from None
    if root is None:
        raise ConfigError(str(source), None, "", "the file is empty; expected targets: [...]")
    top = reader.mapping(root, "", ("targets",), required=("targets",))
    return [_target(reader, node, f"targets[{i}]") for i, node in reader.sequence(top["targets"], "targets")]


def _target(reader: _Reader, node: Node, path: str) -> Target:
    f = reader.mapping(node, path, ("id", "name", "kind", "x", "y", "facing"), required=("id", "x", "y"))
    ident = reader.string(f["id"], f"{path}.id", pattern=TARGET_ID, expected="an id of letters, digits, _ and -")
    name = reader.get(f, "name", path, reader.string, ident)
    kind = reader.get(f, "kind", path, reader.string, "point")
    facing = reader.optional_number(f.get("facing"), f"{path}.facing")
    return Target(
        ident, name, kind, reader.number(f["x"], f"{path}.x"), reader.number(f["y"], f"{path}.y"),
        None if facing is None else math.radians(facing),
    )  # fmt: skip


def standoff(target: Target, grid: OccupancyGrid | None, near: tuple[float, float]) -> tuple[float, float, float]:
    """(x, y, yaw) to inspect ``target`` from, the free one nearest ``near`` (the robot, or its previous stop).

    Raises ValueError when no pose around the target is free with a clear view of it.
    """
    if target.facing is not None:
        directions = [target.facing + k * math.pi / 8 for k in (0, 1, -1, 2, -2)]  # along its facing, then near it
    else:
        directions = [k * math.pi / 8 for k in range(16)]
    candidates = []
    for distance in STANDOFF_ALTERNATIVES:
        for yaw in directions:
            x = target.x - distance * math.cos(yaw)
            y = target.y - distance * math.sin(yaw)
            if grid is None or (
                grid.in_bounds(x, y)
                and grid.clearance(x, y, CLEARANCE) >= CLEARANCE
                # to just short of the target: a panel on a wall sits in an occupied cell itself
                and grid.segment_free(x, y, target.x - 0.25 * math.cos(yaw), target.y - 0.25 * math.sin(yaw))
            ):
                # With a facing, the closest direction to it wins; otherwise the pose nearest the robot.
                deviation = abs(math.remainder(yaw - target.facing, 2 * math.pi)) if target.facing is not None else 0.0
                candidates.append((100.0 * deviation + math.hypot(x - near[0], y - near[1]) + distance, x, y, yaw))
        if candidates and target.facing is not None:
            break  # the facing decides: the first distance that works
    if not candidates:
        raise ValueError(
            f"target {target.id!r} at ({target.x:g}, {target.y:g}): no free pose {STANDOFF_ALTERNATIVES[0]:g}-"
            f"{max(STANDOFF_ALTERNATIVES):g} m from it with a clear view"
        )
    _, x, y, yaw = min(candidates)
    return round(x, 3), round(y, 3), round(math.atan2(math.sin(yaw), math.cos(yaw)), 4)
