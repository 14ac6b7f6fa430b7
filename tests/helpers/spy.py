"""A backend stand-in that records which commands reached it: what an attack or a fuzz run may and may not get
through."""

from __future__ import annotations

import time
from typing import Any

from relay.backends.sim import SimBackend


class CommandSpy:
    """Records every velocity, goal and stop the sim backend receives."""

    def __init__(self, backend: SimBackend) -> None:
        self.calls: list[tuple[float, str, tuple[Any, ...]]] = []
        for name in ("send_velocity", "send_goal", "cancel"):
            original = getattr(backend, name)

            async def spy(*args: Any, _name: str = name, _original: Any = original, **kwargs: Any) -> None:
                self.calls.append((time.monotonic(), _name, args))
                await _original(*args, **kwargs)

            setattr(backend, name, spy)

    def moving_commands(self) -> list[tuple[str, tuple[Any, ...]]]:
        return [(n, a) for _, n, a in self.calls if n == "send_goal" or (n == "send_velocity" and a[1:] != (0.0, 0.0))]
