"""A mission's capture of a target against the target's previous capture: where the place changed since the last
round becomes a ``changed`` finding, outlined on the new image, with its score and the capture it was compared
with (the comparison itself is relay/inspection/change.py). A reading that trends toward its limit over the
target's last rounds makes a ``changed`` finding too, naming it (the rule is relay/inspection/trend.py).

Run after the capture is stored, on a pool of its own (one worker, a short queue: a full pool skips the comparison
with a warning and the mission goes on); the database is read on its own thread. Nothing here is on a stop's path.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from datetime import datetime

from ..station.work import Busy, WorkPool
from .change import Change, ChangeError, compare, decode
from .records import CaptureRecord, FindingRecord, new_id
from .segment import outline_of
from .storage import StoreRunner
from .trend import TREND_ROUNDS, SensorLimit, Trend, series_of, trend_of

logger = logging.getLogger(__name__)


class ChangeWatch:
    def __init__(self, store: StoreRunner, wall_clock: Callable[[], float]) -> None:
        self._store = store
        self._wall = wall_clock
        self._pool = WorkPool("comparing", workers=1, queue=2)

    def close(self) -> None:
        self._pool.shutdown()

    async def since_last_round(
        self, capture: CaptureRecord, jpeg: bytes, place: tuple[float, float]
    ) -> FindingRecord | None:
        """A ``changed`` finding on ``capture`` (stored, of a target) when its image changed from the target's
        previous capture beyond the change threshold; None when it did not, or there is nothing to compare with.
        The previous capture is the newest one whose change no operator marked a false alarm (Store.last_capture_of)."""
        target = capture.target
        if target is None:
            return None
        previous = await self._store(lambda s: s.last_capture_of(target, capture.t, capture.id))
        if previous is None or previous.image is None:
            return None
        sha = previous.image
        earlier = await self._store(lambda s: s.image(sha))
        if earlier is None:
            logger.warning(
                "target %s: the image of its previous capture %s is gone: nothing to compare", target, previous.id
            )
            return None
        try:
            change = await self._pool.run(
                lambda: compare(decode(earlier, "the previous capture"), decode(jpeg, "the capture"))
            )
        except (ChangeError, Busy) as exc:
            logger.warning("target %s: not compared with its previous capture: %s", target, exc)
            return None
        if not change.changed:
            return None
        wall = self._wall()
        return FindingRecord(
            new_id("f"), capture.id, capture.robot, place[0], place[1], "changed", _note(change, previous),
            "rule", wall, wall, capture.mission, target, outline_of(change.mask, capture.width, capture.height),
            round(change.score, 4), previous.id,
        )  # fmt: skip

    async def trends(self, capture: CaptureRecord, limits: Mapping[str, SensorLimit]) -> list[Trend]:
        """Each reading of ``capture`` (stored, of a target) over the target's last ``TREND_ROUNDS`` rounds up to
        it, against its sensor's limit (``limits``: by sensor name; a reading of no known sensor has no trend)."""
        target = capture.target
        if target is None or not capture.readings:
            return []
        until = capture.t
        captures = await self._store(lambda s: s.captures_of(target, until, TREND_ROUNDS))
        return [trend_of(name, series_of(captures, name), limits[name]) for name in capture.readings if name in limits]

    def toward_limits(
        self, capture: CaptureRecord, trends: list[Trend], place: tuple[float, float]
    ) -> list[FindingRecord]:
        """A ``changed`` finding on ``capture`` for each reading trending toward its limit, its note saying which,
        its values and the projected crossing, and keeping its trend."""
        wall = self._wall()
        return [
            FindingRecord(
                new_id("f"),
                capture.id,
                capture.robot,
                place[0],
                place[1],
                "changed",
                f"trending toward its limit: {trend.words()}",
                "rule",
                wall,
                wall,
                capture.mission,
                capture.target,
                trend=trend.record(),
            )
            for trend in trends
            if trend.toward_limit
        ]


def _note(change: Change, previous: CaptureRecord) -> str:
    when = datetime.fromtimestamp(previous.t).astimezone().strftime("%Y-%m-%d %H:%M")
    return f"changed since the last round ({when}): {100 * change.score:.1f} % of the view"
