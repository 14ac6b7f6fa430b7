"""Named poses from a MoveIt SRDF: its ``<group_state>`` entries (``home`` of group ``arm``, ``open`` and ``close``
of group ``gripper`` in turtlebot3_manipulation.srdf).

Reading a file blocks: call :func:`load_group_states` off the event loop.
"""

from __future__ import annotations

from pathlib import Path

import defusedxml.ElementTree as SafeET
from defusedxml import DefusedXmlException

from ..twin.urdf.errors import RobotModelError

#: group -> pose name -> joint name -> position (rad or m)
GroupStates = dict[str, dict[str, dict[str, float]]]


def group_states(srdf_text: str) -> GroupStates:
    """Every ``<group_state>`` of an SRDF document, by group and name. RobotModelError names what is malformed."""
    try:
        root = SafeET.fromstring(srdf_text)
    except (SafeET.ParseError, DefusedXmlException) as err:
        raise RobotModelError(f"the SRDF is not usable XML: {err}") from err
    states: GroupStates = {}
    for state in root.iter("group_state"):
        group, name = state.get("group", ""), state.get("name", "")
        if not group or not name:
            raise RobotModelError("a <group_state> of the SRDF lacks its name or group")
        joints: dict[str, float] = {}
        for joint in state.iter("joint"):
            try:
                joints[joint.get("name", "")] = float(joint.get("value", ""))
            except ValueError:
                raise RobotModelError(
                    f"group_state {name!r}: joint {joint.get('name')!r} has no numeric value"
                ) from None
        states.setdefault(group, {})[name] = joints
    return states


def load_group_states(path: str | Path) -> GroupStates:
    """:func:`group_states` of the SRDF file at ``path`` (blocking)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise RobotModelError(f"cannot read the SRDF {path}: {err}") from err
    return group_states(text)
