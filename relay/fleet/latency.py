"""How late each robot's data and commands are where the relay sees them, per robot and stage, for /metrics (issue
#31: the page shows the same stages as it sees them, xr_client/src/latency.js):

- ``pose`` and ``picture``: the robot's stamp to the relay's wall clock when the pose or the camera frame arrived
  (the publisher's part and the transport's; the page adds the relay-to-page part in its own figures);
- ``command``: a teleop command's age when the relay handed it to the backend (the client's send, estimated from
  its stamps, to the backend call: relay.session.commands).

A stamp from another clock (a recording replayed, a robot clock off by minutes) is not counted. Each robot and stage
keeps its last :data:`SAMPLES` figures; /metrics reports their median. Pure apart from the wall clock passed in.
"""

from __future__ import annotations

import statistics
from collections import deque
from collections.abc import Callable
from typing import Final, Literal

Stage = Literal["pose", "picture", "command"]

SAMPLES: Final = 31
#: Ages outside this (s) compare two clocks that do not agree: not counted.
COMPARABLE: Final = (-0.25, 120.0)


class StageLatency:
    def __init__(self, wall_clock: Callable[[], float]) -> None:
        self._wall_clock = wall_clock
        self._samples: dict[tuple[str, Stage], deque[float]] = {}

    def stamped(self, robot: str, stage: Stage, stamp: float) -> None:
        """Something of ``robot`` stamped ``stamp`` (s, the robot's clock) arrived now."""
        age = self._wall_clock() - stamp
        if COMPARABLE[0] <= age <= COMPARABLE[1]:
            self.took(robot, stage, max(0.0, age))

    def took(self, robot: str, stage: Stage, seconds: float) -> None:
        samples = self._samples.get((robot, stage))
        if samples is None:
            samples = self._samples[(robot, stage)] = deque(maxlen=SAMPLES)
        samples.append(seconds)

    def medians(self) -> dict[tuple[str, Stage], float]:
        """(robot, stage) -> the median of its recent figures (s), for every pair measured."""
        return {key: statistics.median(values) for key, values in sorted(self._samples.items()) if values}
