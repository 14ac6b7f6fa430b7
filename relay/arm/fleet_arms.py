"""The arms of a fleet, read from their files: each robot's chain and named poses, or why it runs without its arm.

An arm whose robots.yaml entry is ``optional`` may lack its files (the demo's robot3 points at the shared data
beside the repository, which a fresh clone does not have): the robot then runs as a base alone, and the reason is
kept for the log and /healthz. An arm described by ``robot_description`` (no file) is not read yet: its robot runs
without its arm, saying so. Reading blocks (tens of milliseconds a URDF): call :func:`load_fleet_arms` off the loop.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property

from ..config import Robot
from ..twin.urdf.errors import RobotModelError
from .model import ArmModel, load_arm
from .named import NamedStates
from .srdf import GroupStates, load_group_states

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class FleetArm:
    model: ArmModel
    poses: GroupStates  # the SRDF's group states (none without an SRDF)

    @cached_property
    def states(self) -> NamedStates:
        """Its named poses and gripper states, as the controllers take them."""
        return NamedStates(self.model, self.poses)

    @property
    def gripper_range(self) -> tuple[float, float] | None:
        """The gripper joint's open and closed positions: the SRDF's ``open`` and ``close`` states, else its limits
        (the upper end open, as OpenManipulator-X's); None without a gripper."""
        gripper = self.model.gripper
        if gripper is None:
            return None
        states = {name: joints[gripper.name] for group in self.poses.values() for name, joints in group.items()
                  if set(joints) == {gripper.name}}  # fmt: skip
        return states.get("open", gripper.upper), states.get("close", gripper.lower)


@dataclass
class FleetArms:
    arms: dict[str, FleetArm] = field(default_factory=dict)  # robot -> its arm
    absent: dict[str, str] = field(default_factory=dict)  # robot -> why its configured arm is not there

    def health(self) -> dict[str, str]:
        """Per robot with an ``arm:`` entry: ``"ready"``, or why it runs without its arm (for /healthz)."""
        return {**{name: "ready" for name in self.arms}, **self.absent}


def load_fleet_arms(robots: Iterable[Robot]) -> FleetArms:
    """The arms of ``robots`` that have an ``arm:`` with a URDF file. Blocking. A required arm whose files are
    malformed raises RobotModelError naming the robot; an ``optional`` one is left out, with the reason logged."""
    loaded = FleetArms()
    for robot in robots:
        arm = robot.arm
        if arm is None:
            continue
        if arm.urdf is None:
            loaded.absent[robot.name] = "runs without its arm: the relay reads no arm from robot_description yet"
            continue
        missing = [str(p) for p in (arm.urdf, arm.srdf) if p is not None and not p.is_file()]
        try:
            if missing:
                raise RobotModelError(f"no such file: {', '.join(missing)}")
            model = load_arm(arm.urdf, arm.base_link, arm.tip_link, arm.gripper_joint)
            poses = load_group_states(arm.srdf) if arm.srdf is not None else {}
        except RobotModelError as err:
            if not arm.optional:
                raise RobotModelError(f"{robot.name}'s arm: {err}") from err
            loaded.absent[robot.name] = f"runs without its arm: {err}"
            logger.warning("%s %s", robot.name, loaded.absent[robot.name])
            continue
        loaded.arms[robot.name] = FleetArm(model, poses)
    return loaded
