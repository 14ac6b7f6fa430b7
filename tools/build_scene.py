"""Write the facility twin: scenes/facility.glb and scenes/facility.yaml from the demo floor plan.

    python tools/build_scene.py [--out-dir scenes]

Both files are committed and must be regenerated after any change to relay/sim/floorplan.py or
relay/twin/facility.py; tests/test_twin_scene.py fails while the committed files differ from a fresh build.
The output is deterministic: running the tool twice writes the same bytes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from relay.sim.floorplan import demo_facility  # noqa: E402
from relay.twin.facility import facility_yaml  # noqa: E402
from relay.twin.facility_glb import facility_glb  # noqa: E402

GLB_NAME = "facility.glb"
YAML_NAME = "facility.yaml"


def build(out_dir: Path) -> list[Path]:
    """Write the glb and the yaml into ``out_dir`` (created if needed); return the paths written."""
    plan = demo_facility()
    out_dir.mkdir(parents=True, exist_ok=True)
    glb = out_dir / GLB_NAME
    glb.write_bytes(facility_glb(plan))
    scene = out_dir / YAML_NAME
    # newline="\n": the same bytes on every platform, since a test compares them.
    with scene.open("w", encoding="utf-8", newline="\n") as stream:
        stream.write(facility_yaml(plan, glb=GLB_NAME))
    return [glb, scene]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", type=Path, default=ROOT / "scenes", help="output folder (default: scenes/)")
    args = parser.parse_args(argv)
    for path in build(args.out_dir):
        print(f"wrote {path} ({path.stat().st_size:,} bytes)")  # noqa: T201 - CLI output
    return 0


if __name__ == "__main__":
    sys.exit(main())
