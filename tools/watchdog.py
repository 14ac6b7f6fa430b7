"""The robot-side stop, without installing the package: ``python tools/watchdog.py --config robots.yaml``.

The same as ``xr-relay watchdog`` (relay/watchdog/node.py; docs/reliability.md shows the set-up).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from relay.watchdog.node import main

if __name__ == "__main__":
    sys.exit(main())
