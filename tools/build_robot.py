"""Write ``scenes/robot.glb``, the robot model the twin shows, from a URDF.

    python tools/build_robot.py [--urdf PATH] [--out scenes/robot.glb] [--namespace NS] [--package-path DIR]...

Without ``--urdf`` it converts the TurtleBot3 Waffle Pi from ``../shared/data/robot/turtlebot3_description``
(relative to the repository root); when that folder is absent it writes the procedural stand-in model
(:func:`relay.twin.urdf.procedural_robot_glb`) and says so. ``package://`` URIs resolve against the ROS
package holding the URDF (its nearest folder with a ``package.xml``), the folder holding that package,
and any ``--package-path``. Prints the size and every conversion warning; exit status 0 unless the URDF
cannot be read or converted (2). The output is deterministic: a test compares the committed file with a
fresh build, so rerun this after changing relay/twin/urdf/.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from relay.twin.urdf import RobotModelError, procedural_robot_glb, urdf_to_glb  # noqa: E402

SHARED_DESCRIPTION = ROOT.parent / "shared" / "data" / "robot" / "turtlebot3_description"
DEFAULT_URDF = SHARED_DESCRIPTION / "urdf" / "turtlebot3_waffle_pi.urdf"
DEFAULT_OUT = ROOT / "scenes" / "robot.glb"


def package_paths_for(urdf_path: Path) -> list[Path]:
    """The package directory holding ``urdf_path`` (nearest ancestor with a ``package.xml``) and its parent,
    so ``package://`` URIs into that package and into sibling packages resolve; ``[]`` if there is none."""
    for folder in urdf_path.resolve().parents:
        if (folder / "package.xml").is_file():
            return [folder, folder.parent]
    return []


def build(
    urdf_path: Path | None = None, *, namespace: str = "", package_paths: Sequence[Path] = ()
) -> tuple[bytes, list[str], str]:
    """GLB bytes, conversion warnings and a description of the source.

    ``urdf_path=None`` means the shared TurtleBot3 Waffle Pi, or the procedural model when the shared data
    is absent. Raises ``OSError`` if an explicit ``urdf_path`` cannot be read and
    :class:`relay.twin.urdf.RobotModelError` if it cannot be converted.
    """
    if urdf_path is None:
        if not DEFAULT_URDF.is_file():
            return procedural_robot_glb(), [], f"the procedural model (no shared data at {DEFAULT_URDF})"
        urdf_path = DEFAULT_URDF
    paths = [*package_paths, *package_paths_for(urdf_path)]
    glb, warnings = urdf_to_glb(urdf_path.read_text(encoding="utf-8"), paths, namespace=namespace)
    return glb, warnings, str(urdf_path)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--urdf", type=Path, help=f"URDF file (default: {DEFAULT_URDF})")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output GLB (default: scenes/robot.glb)")
    parser.add_argument("--namespace", default="", help="value for ${namespace} in frame names, e.g. tb3_0/")
    parser.add_argument(
        "--package-path", type=Path, action="append", default=[], help="extra ROS package or folder of packages"
    )
    args = parser.parse_args(argv)
    try:
        glb, warnings, source = build(args.urdf, namespace=args.namespace, package_paths=args.package_path)
    except (OSError, RobotModelError) as err:
        print(f"error: {err}", file=sys.stderr)  # noqa: T201 - CLI output
        return 2
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_bytes(glb)
    print(f"wrote {args.out} ({len(glb):,} bytes) from {source}")  # noqa: T201 - CLI output
    for warning in warnings:
        print(f"warning: {warning}")  # noqa: T201 - CLI output
    return 0


if __name__ == "__main__":
    sys.exit(main())
