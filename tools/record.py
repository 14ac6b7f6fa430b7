"""Record the fleet's topics from a live ROS 2 graph into an MCAP bag: the same as ``xr-relay record``.

    python tools/record.py --out DIR [--config robots.yaml] [--duration SECONDS]

See relay/cli/record.py for what is recorded and how.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from relay.cli.record import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
