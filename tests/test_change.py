"""What changed at a target between two captures (relay/inspection/change.py), on real photographs: the fisheye
frames of ../shared/data/fisheye. The later capture is the earlier one seen from a slightly different standoff pose
(a perspective warp, as a robot that stops a few centimetres off makes), with a known part of the place changed
(a spill painted on the floor, as the sim's spill grows): the change map must cover that part and nothing else."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import aiohttp
import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from relay.config import FleetConfig
from relay.fleet.events import FrameEvent
from relay.inspection.change import SCORE_THRESHOLD, ChangeError, compare, decode
from relay.inspection.change_watch import ChangeWatch
from relay.inspection.records import CaptureRecord
from relay.inspection.store import Store
from tests.conftest import LOAD_SLACK, SHARED_DATA
from tests.helpers.inspection import TOKEN, operator, relay_with_database

FISHEYE = SHARED_DATA / "fisheye" / "surroundvision_jeyp4"

pytestmark = pytest.mark.skipif(
    not FISHEYE.is_dir(),
    reason=f"the real fisheye photographs are not there ({FISHEYE}); they come with ../shared/data",
)


def photo(name: str) -> NDArray[np.uint8]:
    return decode((FISHEYE / f"{name}.jpg").read_bytes(), name)


def moved(image: NDArray[np.uint8], dx: float, dy: float, tilt: float) -> tuple[NDArray[Any], NDArray[Any]]:
    """The image as seen from a pose a little off: corners moved by a few percent (a homography), and that map."""
    h, w = image.shape[:2]
    corners = np.array([[0, 0], [w, 0], [w, h], [0, h]], np.float32)
    shifted = corners + np.array(
        [[dx * w, dy * h + tilt * h], [dx * w, dy * h - tilt * h], [dx * w, dy * h], [dx * w, dy * h]], np.float32
    )
    homography = cv2.getPerspectiveTransform(corners, shifted)
    return cv2.warpPerspective(image, homography, (w, h), borderMode=cv2.BORDER_REFLECT), homography


def spill(image: NDArray[np.uint8], centre: tuple[float, float], axes: tuple[float, float]) -> NDArray[np.uint8]:
    """A dark green-brown puddle painted at ``centre`` (fractions of the image), ``axes`` (fractions of its width)."""
    out = image.copy()
    h, w = image.shape[:2]
    cv2.ellipse(
        out, (int(centre[0] * w), int(centre[1] * h)), (int(axes[0] * w), int(axes[1] * w)), 0, 0, 360, (40, 90, 60), -1
    )
    return out


def truth(shape: tuple[int, ...], centre: tuple[float, float], axes: tuple[float, float]) -> NDArray[np.bool_]:
    mask = np.zeros(shape[:2], np.uint8)
    h, w = shape[:2]
    cv2.ellipse(
        mask, (int(centre[0] * w), int(centre[1] * h)), (int(axes[0] * w), int(axes[1] * w)), 0, 0, 360, 255, -1
    )
    return mask > 0


@pytest.mark.parametrize("name", ["front", "left", "rear", "right"])
def test_the_same_place_from_a_pose_a_little_off_has_not_changed(name: str) -> None:
    earlier = photo(name)
    later, _ = moved(earlier, 0.02, -0.015, 0.01)
    change = compare(earlier, later)
    assert change.aligned in ("features", "intensity")
    assert change.score < SCORE_THRESHOLD / 2, f"{name}: {change.score:.4f} changed with nothing changed"
    assert change.box() is None or change.score < SCORE_THRESHOLD / 2


@pytest.mark.parametrize("name", ["front", "right"])
def test_a_grown_spill_is_mapped_where_it_grew_and_nowhere_else(name: str) -> None:
    base = photo(name)
    centre = (0.55, 0.7)
    earlier = spill(base, centre, (0.05, 0.03))  # last round: a small puddle
    grown = spill(base, centre, (0.12, 0.07))  # this round: grown, seen from a pose a little off
    later, _ = moved(grown, -0.015, 0.01, -0.008)
    change = compare(earlier, later)
    assert change.changed, f"{name}: score {change.score:.4f}"
    # The simulator's own truth, in the later image: the grown ring (grown less the old puddle), both moved.
    _, homography = moved(grown, -0.015, 0.01, -0.008)
    h, w = later.shape[:2]
    grew = truth(base.shape, centre, (0.12, 0.07)) & ~truth(base.shape, centre, (0.05, 0.03))
    grew = cv2.warpPerspective(grew.astype(np.uint8) * 255, homography, (w, h)) > 127
    grew = cv2.resize(grew.astype(np.uint8), (change.mask.shape[1], change.mask.shape[0])) > 0
    found = change.mask > 0
    covered = np.count_nonzero(found & grew) / np.count_nonzero(grew)
    stray = np.count_nonzero(found & ~grew) / found.size
    assert covered > 0.8, f"{name}: the map covers {covered:.0%} of what grew"
    assert stray < 0.01, f"{name}: {stray:.2%} of the image marked changed outside what grew"
    u0, v0, u1, v1 = change.box() or (0, 0, 0, 0)
    assert u0 < centre[0] < u1 and v0 < centre[1] < v1


def test_another_place_altogether_is_a_change_not_a_match() -> None:
    change = compare(photo("front"), photo("rear"))
    assert change.changed and change.score > 0.3, change.score


def test_captures_that_cannot_be_compared_are_named() -> None:
    with pytest.raises(ChangeError, match="the earlier capture: not an image"):
        decode(b"\xff\xd8 not a jpeg", "the earlier capture")
    with pytest.raises(ChangeError, match="the later capture: a colour image of at least 32x32"):
        compare(photo("front"), np.zeros((8, 8, 3), np.uint8))


async def test_a_target_that_changed_since_the_last_round_gets_a_finding_outlining_the_change(
    fleet_config: FleetConfig, tmp_path: Path
) -> None:
    """Three rounds of a one-target mission, the camera showing a real photograph: the spill there grows between the
    first and the second round (seen from a pose a little off), not between the second and the third. The second
    round's capture gets a ``changed`` finding, outlining the grown spill on its image, with its score and the first
    round's capture as its baseline, whose image is its ``before`` (served over HTTP); the third gets none. A relay
    restarted on the same database sends it with the same ``before``."""
    base = photo("front")
    centre = (0.55, 0.7)
    rounds = [
        spill(base, centre, (0.05, 0.03)),
        moved(spill(base, centre, (0.12, 0.07)), -0.015, 0.01, -0.008)[0],
        moved(spill(base, centre, (0.12, 0.07)), -0.015, 0.01, -0.008)[0],
    ]
    pictures = [cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 92])[1].tobytes() for image in rounds]
    h, w = base.shape[:2]
    running = await relay_with_database(fleet_config, tmp_path)
    shown = {"round": 0}

    async def camera(robot: str, name: str) -> FrameEvent:
        return FrameEvent(robot, name, time.time(), w, h, pictures[shown["round"]])

    backend: Any = running.relay.backend
    backend.snapshot = camera
    try:
        client = await operator(running)
        added = await client.request({"identifier": "target/add", "target": "drum", "x": 3.0, "y": 3.2, "name": "Drum"})
        assert added["identifier"] == "ack", added
        changed: list[list[dict[str, Any]]] = []
        for index in range(3):
            shown["round"] = index
            start = len(client.messages)
            reply = await client.request(
                {"identifier": "mission/start", "robot": "robot1", "steps": [{"inspect": "drum"}]}, timeout=30
            )
            assert reply["identifier"] == "ack", reply
            await client.wait_for(
                lambda m: m["identifier"] == "mission" and m["state"] in ("done", "aborted"), 60 + LOAD_SLACK, start
            )
            found = [m for _, m in client.messages[start:] if m["identifier"] == "finding"]
            assert any(f["source"] == "rule" and f["status"] in ("ok", "anomaly") for f in found), found
            changed.append([f for f in found if f["status"] == "changed"])
        assert changed[0] == [] and changed[2] == [], changed
        [finding] = changed[1]
        assert finding["note"].startswith("changed since the last round (") and finding["target"] == "drum"
        assert finding["change"] > SCORE_THRESHOLD and finding["note"].endswith(
            f"{100 * finding['change']:.1f} % of the view"
        )
        first = next(f for _, f in client.messages if f["identifier"] == "finding" and f["target"] == "drum")
        assert finding["baseline"] == first["capture"] != finding["capture"]
        assert finding["before"] == first["image"] != finding["image"] and first["image"].startswith("/captures/")
        async with (
            aiohttp.ClientSession() as http,
            http.get(f"{running.url}{finding['before']}?token={TOKEN}") as response,
        ):
            assert response.status == 200 and await response.read() == pictures[0]
        assert all(f["before"] is None for f in changed[0] + [first])
        # The card's trend: the reading nearest its limit over the target's two rounds so far, this one's last.
        trend = finding["trend"]
        assert (
            trend is not None
            and len(trend["points"]) == 2
            and trend["points"][-1][1] == finding["readings"][trend["sensor"]]
        )
        assert trend["unit"] == next(s.unit for s in fleet_config.robots[0].sensors if s.name == trend["sensor"])
        alert = await client.wait_for(lambda m: m["identifier"] == "alert" and m["subject"] == finding["id"], 30)
        assert (alert["kind"], alert["severity"]) == ("changed", "warning") and alert["text"].startswith(
            "Changed at Drum"
        )
        outline = np.array(finding["region"], np.int32)
        u0, v0 = outline.min(axis=0)
        u1, v1 = outline.max(axis=0)
        assert u0 < centre[0] * w < u1 and v0 < centre[1] * h < v1, (u0, v0, u1, v1)
        assert (u1 - u0) < 0.5 * w and (v1 - v0) < 0.5 * h  # the spill, not the view
        await client.close()
    finally:
        await running.runner.cleanup()

    running = await relay_with_database(fleet_config, tmp_path)
    try:
        client = await operator(running)
        await client.wait_for(lambda m: m["identifier"] == "finding" and m["id"] == finding["id"])
        again = [m for _, m in client.messages if m["identifier"] == "finding" and m["id"] == finding["id"]]
        reply = await client.request({"identifier": "findings/page", "limit": 50})
        page = next(m for _, m in client.messages if m["identifier"] == "findings" and m["id"] == reply["id"])
        paged = [f for f in page["findings"] if f["id"] == finding["id"]]
        assert again == paged == [finding], (again, paged)
        await client.close()
    finally:
        await running.runner.cleanup()


async def test_a_round_is_compared_with_the_capture_before_one_marked_a_false_alarm(tmp_path: Path) -> None:
    """Three captures of a target, each showing the place otherwise: the third is compared with the second; once the
    second's change is marked a false alarm (its image was noise), with the first, the last image accepted."""
    base = photo("front")
    pictures = [base, spill(base, (0.3, 0.65), (0.08, 0.05)), spill(base, (0.7, 0.65), (0.08, 0.05))]
    jpegs = [cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 92])[1].tobytes() for image in pictures]
    h, w = base.shape[:2]
    with Store.open(str(tmp_path / "inspection.sqlite"), tmp_path / "images") as store:

        async def on_store(work: Callable[[Store], Any], request_id: Any = None) -> Any:
            return work(store)  # the store's own thread is the relay's business; here the loop's will do

        watch = ChangeWatch(on_store, lambda: 1795388600.0)
        try:
            captures = [
                store.add_capture(CaptureRecord(f"c-{n}", "robot1", 1795388500.0 + n, 3.0, 2.0, 0.0, {}, "m-1",
                                                "drum", None, w, h), jpeg)
                for n, jpeg in enumerate(jpegs, 1)
            ]  # fmt: skip
            second = await watch.since_last_round(captures[1], jpegs[1], (3.0, 3.2))
            assert second is not None and (second.status, second.baseline) == ("changed", "c-1")
            assert second.change is not None and second.change > SCORE_THRESHOLD
            store.add_finding(second)
            third = await watch.since_last_round(captures[2], jpegs[2], (3.0, 3.2))
            assert third is not None and third.baseline == "c-2"
            store.update_finding(second.id, status="false_alarm", note="a bucket, moved back since", updated=1.0)
            third = await watch.since_last_round(captures[2], jpegs[2], (3.0, 3.2))
            assert third is not None and third.baseline == "c-1"
            assert third.note.startswith("changed since the last round (") and third.status == "changed"
        finally:
            watch.close()
