"""A client's lane for the live 3D map (issue #33): the lowest priority, one batch of frames at most.

A batch is a ``voxel_map`` text message and the binary frames of block records it announces
(relay/mapping/stream.py). The writer (relay/station/hub.py) takes from this lane only when every other lane is empty,
so a pose, a reply or an estop never waits behind more than the one map frame being sent (at most
:data:`relay.mapping.stream.MAX_FRAME` bytes). The lane takes a new batch only when the last one is gone: a client that
reads slowly is not sent every change as it happens, but, once it has read, one batch of all it lacks since the
version it holds. Its memory is that one batch (at most the whole map, which robots.yaml's budget bounds; clients at
the same version share the same bytes).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence


class MapLane:
    def __init__(self) -> None:
        #: The map's version this client will hold once the lane is sent (0: none yet).
        self.version = 0
        self._frames: deque[tuple[bool, bytes]] = deque()

    def __len__(self) -> int:
        return len(self._frames)

    @property
    def idle(self) -> bool:
        """Whether the lane takes a batch now."""
        return not self._frames

    def put(self, frames: Sequence[tuple[bool, bytes]], version: int) -> bool:
        """A batch of (binary, bytes) frames that brings the client to ``version``; False (and nothing queued) while
        the previous batch is still waiting."""
        if self._frames:
            return False
        self._frames.extend(frames)
        self.version = version
        return True

    def pop(self) -> tuple[bool, bytes]:
        return self._frames.popleft()

    def clear(self) -> None:
        self._frames.clear()
