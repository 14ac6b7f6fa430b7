"""GrabCut from one tap (relay.inspection.segment) on a real fisheye frame and on a synthetic object of known shape."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from relay.inspection.segment import SegmentError, region_from_point
from tests.conftest import SHARED_DATA

REAR = SHARED_DATA / "fisheye" / "surroundvision_jeyp4" / "rear.jpg"
#: The cardboard box in the middle of rear.jpg (1280x720): a tap on its front face.
BOX_TAP = (680, 380)
#: The box's outline, annotated by hand on a 1.6x zoom of the frame (full-resolution pixels, u right, v down).
BOX_OUTLINE = ((524, 304), (824, 301), (890, 394), (856, 469), (514, 469), (493, 401), (515, 341))


def real_jpeg(path: Path) -> bytes:
    if not path.is_file():
        pytest.skip(f"shared test data not found at {path} (../shared/data beside the project)")
    return path.read_bytes()


def polygon_mask(polygon: tuple[tuple[int, int], ...] | NDArray[np.int32], shape: tuple[int, int]) -> NDArray[np.bool_]:
    mask = np.zeros(shape, np.uint8)
    cv2.fillPoly(mask, [np.asarray(polygon, np.int32).reshape(-1, 1, 2)], 1)
    return mask.astype(bool)


def iou(a: NDArray[np.bool_], b: NDArray[np.bool_]) -> float:
    return float((a & b).sum() / (a | b).sum())


def test_a_tap_on_the_box_of_a_real_fisheye_frame_outlines_the_box() -> None:
    jpeg = real_jpeg(REAR)
    height, width = 720, 1280
    polygon = region_from_point(jpeg, *BOX_TAP)

    assert 3 <= len(polygon) <= 64
    assert all(0 <= u < width and 0 <= v < height for u, v in polygon)
    contour = np.asarray(polygon, np.int32).reshape(-1, 1, 2)
    assert cv2.pointPolygonTest(contour, (float(BOX_TAP[0]), float(BOX_TAP[1])), measureDist=False) >= 0
    area = cv2.contourArea(contour) / (width * height)
    assert 0.001 < area < 0.5, area

    # A single region: the filled polygon is one connected component with one outer contour.
    mask = polygon_mask(polygon, (height, width))
    count, _ = cv2.connectedComponents(mask.astype(np.uint8))
    assert count == 2  # background and the region
    outer, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    assert len(outer) == 1

    # And it is the box: it overlaps the hand-drawn outline well.
    assert iou(mask, polygon_mask(BOX_OUTLINE, (height, width))) > 0.8


def test_the_same_input_gives_the_same_outline() -> None:
    jpeg = real_jpeg(REAR)
    outlines = set()
    for seed in (1, 2, 3, 5):
        # Whatever the caller did to OpenCV's RNG in between: without the reseed inside, these four runs give
        # four different outlines (measured), as GrabCut's k-means draws from that RNG.
        cv2.setRNGSeed(seed)
        cv2.randu(np.zeros((10, 10)), np.zeros(1), np.ones(1))
        outlines.add(region_from_point(jpeg, *BOX_TAP))
    assert len(outlines) == 1


def synthetic_circle() -> tuple[bytes, NDArray[np.bool_], tuple[int, int]]:
    """A dark disc on a bright, textured background (coloured noise, blurred like a real sensor's), as a JPEG."""
    rng = np.random.default_rng(7)
    height, width = 480, 640
    noise = rng.integers(0, 256, (height // 8, width // 8, 3), dtype=np.uint8)
    texture = cv2.resize(noise, (width, height), interpolation=cv2.INTER_CUBIC)
    image = (140 + texture.astype(np.int16) // 3).astype(np.uint8)  # 140..225: a busy but bright floor
    centre, radius = (400, 200), 70
    disc = np.zeros((height, width), np.uint8)
    cv2.circle(disc, centre, radius, 1, thickness=-1)
    shade = (30 + rng.integers(0, 25, (height, width, 1))).astype(np.uint8)  # a dark object, not a flat one
    image = np.where(disc[..., None] == 1, shade, image).astype(np.uint8)
    ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 85])
    assert ok
    return jpeg.tobytes(), disc.astype(bool), (centre[0] + 20, centre[1] - 15)  # a tap off the centre


def test_a_known_object_is_recovered() -> None:
    jpeg, truth, tap = synthetic_circle()
    polygon = region_from_point(jpeg, *tap)
    found = polygon_mask(polygon, truth.shape)
    assert iou(found, truth) > 0.8, iou(found, truth)


def test_the_outline_is_in_full_resolution_pixels_whatever_the_working_size() -> None:
    jpeg, truth, tap = synthetic_circle()
    for max_side in (160, 320, 640):
        found = polygon_mask(region_from_point(jpeg, *tap, max_side=max_side), truth.shape)
        assert iou(found, truth) > 0.8, (max_side, iou(found, truth))


@pytest.mark.parametrize("point", [(-1, 10), (10, -1), (640, 10), (10, 480), (10_000, 10_000)])
def test_a_point_outside_the_image_is_refused(point: tuple[int, int]) -> None:
    jpeg, _, _ = synthetic_circle()
    with pytest.raises(SegmentError, match=r"outside the 640x480 image"):
        region_from_point(jpeg, *point)


@pytest.mark.parametrize("data", [b"", b"not a jpeg at all", b"\xff\xd8\xff\xe0" + b"\x00" * 64])
def test_undecodable_bytes_are_refused(data: bytes) -> None:
    with pytest.raises(SegmentError, match=r"image"):
        region_from_point(data, 0, 0)


def test_a_tiny_image_is_refused_not_crashed() -> None:
    ok, jpeg = cv2.imencode(".jpg", np.full((8, 8, 3), 128, np.uint8))
    assert ok
    with pytest.raises(SegmentError, match=r"too small"):
        region_from_point(jpeg.tobytes(), 4, 4)


def test_segment_error_is_a_value_error() -> None:
    assert issubclass(SegmentError, ValueError)


def test_a_tap_where_nothing_stands_out_is_refused() -> None:
    ok, jpeg = cv2.imencode(".jpg", np.full((480, 640, 3), 128, np.uint8))  # a flat grey wall
    assert ok
    with pytest.raises(SegmentError, match=r"nothing stands out at \(320, 240\)"):
        region_from_point(jpeg.tobytes(), 320, 240)
