"""Captures and what is made of them: findings (by rule or by hand), regions, and targets from a pixel.

A capture is the robot's first camera's image (a snapshot), its readings, its pose and the time, stored with the
image beside the database (relay.inspection.store). At a mission's ``inspect`` step a rule makes a finding:
``anomaly`` naming each reading over its threshold (robots.yaml's ``warn_above``/``warn_below``), else ``ok``
with the readings, and a ``changed`` one outlining what changed since the target's previous capture, and one for
each reading trending toward its limit (relay.inspection.change_watch); a ``capture`` step makes one only for an
anomaly. Operators mark and update findings, ask for the region around a point of an image (GrabCut, on a pool of
its own), and add targets where a pixel looks.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from ..errors import CommandRejected
from ..session.protocol import ErrorCode, RequestId
from ..station.work import Busy, WorkPool
from .change_watch import ChangeWatch
from .messages import FINDINGS_ON_CONNECT, finding_message, region_message
from .pixel import pixel_to_map
from .records import AlertRecord, AlertSeverity, CaptureRecord, FindingRecord, MissionRecord, Step, Target, new_id
from .storage import StoreRunner
from .target_book import TargetBook
from .trend import concern
from .wire import FindingMark, RegionRequest, TargetAdd

if TYPE_CHECKING:
    from ..backends.base import Backend
    from ..config import Robot
    from ..fleet.occupancy import OccupancyGrid
    from ..fleet.state import FleetState
    from ..session.clients import Client
    from ..station.outbox import Outbox
    from .store import Store

logger = logging.getLogger(__name__)
T = TypeVar("T")


def past_limits(robot: Robot, warnings: list[dict[str, Any]]) -> str:
    """``gas 698.2 ppm (over 400 ppm); ...``: each reading past its sensor's limit (robots.yaml)."""
    specs = {s.name: s for s in robot.sensors}

    def over(name: str, value: float, unit: str) -> str:
        spec = specs.get(name)
        limit = spec.warn_above if spec and spec.warn_above is not None and value > spec.warn_above else None
        below = spec.warn_below if spec and limit is None else None
        bound = f"over {limit:g}" if limit is not None else f"under {below:g}" if below is not None else "out of range"
        return f"{name} {value:.1f} {unit} ({bound} {unit})"

    return "; ".join(over(m["name"], m["value"], m["unit"]) for m in warnings)


def _adding(finding: FindingRecord) -> Callable[[Store], FindingRecord]:
    return lambda store: store.add_finding(finding)


class RaiseAlert(Protocol):
    """relay.inspection.alerts.Alerts.raise_alert."""

    def __call__(
        self, kind: str, text: str, *, robot: str | None = ..., subject: str | None = ..., severity: AlertSeverity = ...
    ) -> AlertRecord: ...


class Captures:
    def __init__(
        self,
        robots: Mapping[str, Robot],
        *,
        backend: Backend,
        fleet: FleetState,
        outbox: Outbox,
        book: TargetBook,
        store: StoreRunner,
        alert: RaiseAlert,
        map_grid: Callable[[], OccupancyGrid | None],
        clock: Callable[[], float],
        wall_clock: Callable[[], float] = time.time,
        marked: Callable[[str | None], None] = lambda target: None,
    ) -> None:
        """``marked``: told the target of every finding an operator marks (None: a capture of no target)."""
        self.robots = robots
        self._marked = marked
        self._backend, self._fleet, self._outbox, self._book, self._store = backend, fleet, outbox, book, store
        self._alert = alert
        self._map_grid, self._clock, self._wall = map_grid, clock, wall_clock
        self._segmenting = WorkPool("segmenting", workers=1, queue=2)
        self._changes = ChangeWatch(store, wall_clock)
        self.recent: list[Any] = []  # the newest finding messages, for clients that connect later

    def close(self) -> None:
        self._segmenting.shutdown()
        self._changes.close()

    async def for_mission(self, record: MissionRecord, step: Step) -> None:
        robot = self.robots[record.robot]
        capture, jpeg, sensors = await self._snap(robot.name, record.id, step.target)
        stored = await self._store(lambda s: s.add_capture(capture, jpeg))
        wall = stored.t
        warnings = [m for m in sensors.values() if m["warning"]]
        if step.kind != "inspect" and not warnings:
            return
        if warnings:
            note = past_limits(robot, warnings)
        else:
            note = "within thresholds: " + ", ".join(
                f"{m['name']} {m['value']:.1f} {m['unit']}" for m in sensors.values()
            )
        target = self._book.targets.get(step.target or "")
        trends = await self._changes.trends(stored, {s.name: s for s in robot.sensors})
        shown = concern(trends)  # the reading the card's trend shows
        finding = FindingRecord(
            new_id("f"), stored.id, robot.name, target.x if target else stored.x, target.y if target else stored.y,
            "anomaly" if warnings else "ok", note, "rule", wall, wall, record.id, step.target,
            trend=shown.record() if shown else None,
        )  # fmt: skip
        await self._announce(await self._store(lambda s: s.add_finding(finding)), stored)
        if warnings:
            self._alert_of(finding, "critical")
        place = (finding.x, finding.y)
        # What changed there since the last round: the view, and readings heading for their limits.
        changed = None if jpeg is None else await self._changes.since_last_round(stored, jpeg, place)
        for made in [changed, *self._changes.toward_limits(stored, trends, place)]:
            if made is not None:
                made = made if made.trend else replace(made, trend=finding.trend)
                await self._announce(await self._store(_adding(made)), stored)
                self._alert_of(made)

    def _place(self, target: str | None, x: float, y: float) -> str:
        known = self._book.targets.get(target or "")
        return known.name if known is not None else f"({x:.1f}, {y:.1f})"

    def _alert_of(self, finding: FindingRecord, severity: AlertSeverity = "warning") -> None:
        """The alert of a finding made as, or changed to, a status someone must see: ``anomaly``, or ``changed``
        (a kind of its own, so that a webhook may take changes without anomalies, or the reverse)."""
        if finding.status not in ("anomaly", "changed"):
            return
        place = self._place(finding.target, finding.x, finding.y)
        text = f"{finding.status.capitalize()} at {place} ({finding.robot})"
        text += f": {finding.note}" if finding.note else ""
        self._alert(finding.status, text, robot=finding.robot, subject=finding.id, severity=severity)

    async def _snap(
        self, robot_name: str, mission: str | None, target: str | None, request_id: RequestId | None = None
    ) -> tuple[CaptureRecord, bytes | None, dict[str, Any]]:
        """A capture of the robot now, not yet stored: its camera image (for a mission, none when it has no camera or
        the rendering pool is full: the readings still count; for an operator's request, ``request_id``, a full pool
        is a refusal), its pose and readings; and the sensors' state at that moment."""
        robot = self.robots[robot_name]
        camera = robot.camera(None)
        frame = None
        if camera is not None:
            try:
                frame = await self._backend.snapshot(robot.name, camera.name)
            except CommandRejected as exc:
                if request_id is not None:
                    raise CommandRejected(exc.code, f"target/add: {exc}", request_id) from None
                logger.warning("capture of %s: no image: %s", robot.name, exc)
        state = self._fleet.snapshot(self._clock())[robot.name]
        pose, sensors = state["pose"], state["sensors"]
        capture = CaptureRecord(
            new_id("c"), robot.name, self._wall(),
            pose["x"] if pose else 0.0, pose["y"] if pose else 0.0, pose["yaw"] if pose else 0.0,
            {name: m["value"] for name, m in sensors.items()}, mission, target,
            None, frame.width if frame else 0, frame.height if frame else 0,
        )  # fmt: skip
        return capture, frame.jpeg if frame else None, sensors

    async def _announce(self, finding: FindingRecord, capture: CaptureRecord) -> None:
        before = None
        baseline = finding.baseline
        if baseline is not None:  # a change finding: its before image is the baseline capture's (off the loop)
            compared: CaptureRecord | None = await self._store(lambda s: s.capture(baseline))
            before = None if compared is None else compared.image
        message = finding_message(finding, capture.image, capture.readings, before)
        kept = [m for m in self.recent if m["id"] != finding.id][-FINDINGS_ON_CONNECT:]
        self.recent = [*kept, message]
        self._outbox.broadcast(message)

    # -- findings, regions, targets ---------------------------------------------------------------

    async def finding(self, client: Client, command: FindingMark) -> None:
        wall = self._wall()
        if command.action == "mark":
            assert command.capture is not None and command.status is not None
            capture = await self._capture_record(command.capture, command.id)
            target = self._book.targets.get(capture.target or "")
            finding = FindingRecord(
                new_id("f"), capture.id, capture.robot, target.x if target else capture.x,
                target.y if target else capture.y, command.status, command.note or "", "operator", wall, wall,
                capture.mission, capture.target, command.region,
            )  # fmt: skip
            await self._announce(await self._store(lambda s: s.add_finding(finding), command.id), capture)
            self._alert_of(finding)
            self._marked(finding.target)
            return
        assert command.finding is not None
        finding_id = command.finding

        def update(store: Store) -> tuple[FindingRecord | None, FindingRecord]:
            before = store.finding(finding_id)
            return before, store.update_finding(
                finding_id, status=command.status, note=command.note, region=command.region, updated=wall
            )

        before, updated = await self._store(update, command.id)
        await self._announce(updated, await self._capture_record(updated.capture, command.id))
        if before is None or before.status != updated.status:  # a new note on the same status alerts nobody again
            self._alert_of(updated)

    async def _capture_record(self, capture_id: str, request_id: RequestId) -> CaptureRecord:
        capture: CaptureRecord | None = await self._store(lambda s: s.capture(capture_id), request_id)
        if capture is None:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"no capture {capture_id[:80]!r}", request_id)
        return capture

    async def region(self, client: Client, command: RegionRequest) -> None:
        from .segment import SegmentError, region_from_point

        capture = await self._capture_record(command.capture, command.id)
        sha = capture.image
        jpeg = None if sha is None else await self._store(lambda s: s.image(sha), command.id)
        if jpeg is None:
            raise CommandRejected(ErrorCode.NO_CAMERA, f"region: capture {capture.id} has no image", command.id)
        try:
            outline = await self._segmenting.run(lambda: region_from_point(jpeg, command.u, command.v))
        except SegmentError as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"region: {exc}", command.id) from None
        except Busy as exc:
            raise CommandRejected(ErrorCode.BUSY, f"region: {exc}; try again shortly", command.id) from None
        self._outbox.to(client, region_message(command.id, capture.id, outline))

    async def add_target(self, client: Client, command: TargetAdd) -> None:
        if command.robot is not None:
            await self._target_from_live(client, command)
            return
        x, y = command.x, command.y
        if command.capture is not None:
            assert command.u is not None and command.v is not None
            capture = await self._capture_record(command.capture, command.id)
            camera = self.robots[capture.robot].camera(None)
            if camera is None or not capture.width:
                raise CommandRejected(ErrorCode.NO_CAMERA, f"target/add: capture {capture.id} has no image", command.id)
            try:
                x, y = pixel_to_map(
                    camera, capture.width, capture.height, (capture.x, capture.y, capture.yaw), command.u, command.v,
                    self._map_grid(),
                )  # fmt: skip
            except ValueError as exc:
                raise CommandRejected(ErrorCode.BAD_REQUEST, f"target/add: {exc}", command.id) from None
        assert x is not None and y is not None
        target = Target(command.target, command.name or command.target, command.kind or "point", x, y, command.facing)
        await self._book.add([target], "target/add", command.id)

    async def _target_from_live(self, client: Client, command: TargetAdd) -> None:
        """A target where pixel (u, v) of the robot's live camera looks (pixels of the camera's configured size, as
        its lens model has them): a capture now, the target from its pose, a ``needs_review`` finding about it for
        the operator to review, and the region around that pixel proposed to the requester (GrabCut) before the
        ``ack``. Nothing is stored or added when the pixel looks at nothing; a region that cannot be segmented
        leaves the target and the finding, and the ``ack`` comes without an outline."""
        from .segment import SegmentError, region_from_point

        assert command.robot is not None and command.u is not None and command.v is not None
        robot = self.robots.get(command.robot)
        if robot is None:
            raise CommandRejected(
                ErrorCode.UNKNOWN_ROBOT,
                f"target/add: unknown robot {command.robot[:80]!r}; the robots are {', '.join(sorted(self.robots))}",
                command.id,
            )
        camera = robot.camera(None)
        if camera is None:
            raise CommandRejected(ErrorCode.NO_CAMERA, f"target/add: {robot.name} has no camera", command.id)
        capture, jpeg, sensors = await self._snap(robot.name, None, command.target, command.id)
        if jpeg is None or not capture.width:
            raise CommandRejected(ErrorCode.NO_CAMERA, f"target/add: no image from {robot.name} yet", command.id)
        # The operator's pixel is of the configured size; the capture may be of another (a camera set to publish
        # smaller images than its calibration): the same point of the picture.
        u, v = command.u * capture.width / camera.width, command.v * capture.height / camera.height
        try:
            x, y = pixel_to_map(
                camera, capture.width, capture.height, (capture.x, capture.y, capture.yaw), u, v, self._map_grid()
            )
        except ValueError as exc:
            raise CommandRejected(ErrorCode.BAD_REQUEST, f"target/add: {exc}", command.id) from None
        target = Target(command.target, command.name or command.target, command.kind or "point", x, y, None)
        self._book.check([target], "target/add", command.id)  # before anything is stored
        stored = await self._store(lambda s: s.add_capture(capture, jpeg), command.id)
        await self._book.add([target], "target/add", command.id)
        readings = ", ".join(f"{m['name']} {m['value']:.1f} {m['unit']}" for m in sensors.values())
        note = f"marked on {robot.name}'s camera" + (f"; {readings}" if readings else "")
        finding = FindingRecord(
            new_id("f"), stored.id, robot.name, x, y, "needs_review", note, "operator", stored.t, stored.t,
            None, target.id,
        )  # fmt: skip
        await self._announce(await self._store(lambda s: s.add_finding(finding), command.id), stored)
        warnings = [m for m in sensors.values() if m["warning"]]
        if warnings:  # a needs_review finding does not name them: the readings raise their own alert
            self._alert(
                "threshold", f"Past its limit at {target.name} ({robot.name}): {past_limits(robot, warnings)}",
                robot=robot.name, subject=stored.id, severity="critical",
            )  # fmt: skip
        try:
            outline = await self._segmenting.run(lambda: region_from_point(jpeg, int(u), int(v)))
        except (SegmentError, Busy) as exc:
            logger.info("target/add %s: no region proposed: %s", command.target, exc)
            return
        self._outbox.to(client, region_message(command.id, stored.id, outline))
