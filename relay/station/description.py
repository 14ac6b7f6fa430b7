"""The fleet as clients see it in ``hello``: each robot's colour, model, cameras, sensors and limits."""

from __future__ import annotations

from ..config import Robot
from ..session.protocol import camera_identifier
from .messages import Lens, RobotDescription


def lens_description(robot: Robot, camera_name: str) -> Lens:
    camera = robot.camera(camera_name)
    if camera is None:
        raise KeyError(f"{robot.name} has no camera named {camera_name!r}")
    lens: Lens = {"model": camera.lens.model, "fov": camera.lens.fov}
    if camera.lens.k is not None and camera.lens.d is not None:
        lens["K"] = list(camera.lens.k)
        lens["D"] = list(camera.lens.d)
    return lens


def describe_robot(robot: Robot, model_url: str | None = None) -> RobotDescription:
    """``model_url`` is a model built from the robot's robot_description; it replaces robots.yaml's ``model``."""
    return {
        "name": robot.name,
        "colour": robot.colour,
        "team": robot.team,
        "model": model_url or robot.model or "",
        "cameras": [
            {
                "name": c.name,
                "identifier": camera_identifier(robot.name, c.name),
                "lens": lens_description(robot, c.name),
                "width": c.width,
                "height": c.height,
                # H.264 (4:2:0) needs an even width and height.
                "codecs": ["jpeg", "h264"] if c.width % 2 == 0 and c.height % 2 == 0 else ["jpeg"],
                "on_arm": robot.arm is not None and robot.arm.camera == c.name,
            }
            for c in robot.cameras
        ],
        "sensors": [
            {"name": s.name, "unit": s.unit, "warn_above": s.warn_above, "warn_below": s.warn_below}
            for s in robot.sensors
        ],
        "limits": {"linear": robot.limits.linear, "angular": robot.limits.angular},
    }
