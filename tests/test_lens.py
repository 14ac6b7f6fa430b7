"""Lens models: known angles land on the documented pixels (docs/lenses.md), round trips are exact, and the
OpenCV fisheye model agrees with OpenCV itself on real calibrated intrinsics."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
import yaml
from numpy.typing import NDArray

from relay.config import Lens
from relay.media.lens import LensModel, pixel_grid, project, unproject
from tests.conftest import SHARED_DATA

CAMERAS_PARAM = SHARED_DATA / "fisheye" / "surroundvision_jeyp4" / "camerasParam.yaml"

# The front camera of that rig, copied here (not read from the file) for the table in docs/lenses.md.
FRONT_K = (774.6536281807633, 0.0, 987.610615957488, 0.0, 776.8351403236894, 592.2748935047063, 0.0, 0.0, 1.0)
FRONT_D = (-0.019489941171064756, -0.0030279815071226094, -0.0006303865899399078, 0.0000929330887373027)


def direction(theta_deg: float, phi_deg: float = 0.0) -> NDArray[np.float64]:
    """Unit optical-frame direction at ``theta`` from the axis, azimuth ``phi`` from +x (right) towards +y (down)."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([[math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)]])


def closed_form_radius(model: str, theta: float, fov_deg: float, size: int) -> float:
    """Pixel radius of ``theta`` on a ``size`` x ``size`` image, written out independently of relay.media.lens."""
    half = math.radians(fov_deg) / 2.0
    rim = size / 2.0
    if model == "equidistant":
        return rim * theta / half
    if model == "equisolid":
        return rim * math.sin(theta / 2.0) / math.sin(half / 2.0)
    if model == "stereographic":
        return rim * math.tan(theta / 2.0) / math.tan(half / 2.0)
    assert model == "pinhole"
    return rim * math.tan(theta) / math.tan(half)


# docs/lenses.md, "Reference values": 640 x 640 image (centre 319.5, 319.5), fov 180 for the circle models and
# 90 for pinhole; pixel radius from the centre for angles from the optical axis.
REFERENCE = [
    ("equidistant", 180.0, [(0, 0.0), (30, 106.667), (45, 160.0), (60, 213.333), (90, 320.0)]),
    ("equisolid", 180.0, [(0, 0.0), (30, 117.128), (45, 173.183), (60, 226.274), (90, 320.0)]),
    ("stereographic", 180.0, [(0, 0.0), (30, 85.744), (45, 132.548), (60, 184.752), (90, 320.0)]),
    ("pinhole", 90.0, [(0, 0.0), (30, 184.752), (45, 320.0)]),
]


@pytest.mark.parametrize(("model", "fov", "table"), REFERENCE, ids=[r[0] for r in REFERENCE])
def test_reference_angles_land_on_documented_pixels(model: str, fov: float, table: list[tuple[float, float]]) -> None:
    lens = LensModel.create(model, 640, 640, fov)
    for theta, radius in table:
        # To the right (+x) the pixel is right of the centre; downwards (+y) it is below it.
        right, ok_right = project(lens, direction(theta, 0.0))
        down, ok_down = project(lens, direction(theta, 90.0))
        assert ok_right[0] and ok_down[0], (model, theta)
        np.testing.assert_allclose(right[0], [319.5 + radius, 319.5], atol=1e-3)
        np.testing.assert_allclose(down[0], [319.5, 319.5 + radius], atol=1e-3)


@pytest.mark.parametrize(
    ("model", "fov"),
    [
        (model, fov)
        for model in ("equidistant", "equisolid", "stereographic", "pinhole")
        for fov in (60.0, 120.0, 170.0, 200.0, 270.0)
        if model != "pinhole" or fov < 180.0  # pinhole lenses stop below 180 degrees
    ],
)
def test_intermediate_angles_match_the_closed_form(model: str, fov: float) -> None:
    size = 512
    lens = LensModel.create(model, size, size, fov)
    centre = (size - 1) / 2.0
    for fraction in (0.1, 0.33, 0.5, 0.77, 0.95):
        theta = fraction * math.radians(fov) / 2.0
        for phi in (0.0, 37.0, 135.0, 250.0):
            pixel, ok = project(lens, direction(math.degrees(theta), phi))
            radius = closed_form_radius(model, theta, fov, size)
            expected = [centre + radius * math.cos(math.radians(phi)), centre + radius * math.sin(math.radians(phi))]
            assert ok[0]
            np.testing.assert_allclose(pixel[0], expected, atol=1e-6)


@pytest.mark.parametrize("model", ["equidistant", "equisolid", "stereographic"])
@pytest.mark.parametrize(("width", "height", "fov"), [(640, 640, 180.0), (640, 480, 220.0), (300, 500, 120.0)])
def test_circle_models_put_half_the_fov_on_the_rim(model: str, width: int, height: int, fov: float) -> None:
    lens = LensModel.create(model, width, height, fov)
    centre = np.array([(width - 1) / 2.0, (height - 1) / 2.0])
    rim = min(width, height) / 2.0
    axis, ok = project(lens, np.array([[0.0, 0.0, 1.0]]))
    assert ok[0]
    np.testing.assert_allclose(axis[0], centre, atol=1e-9)
    for phi in (0.0, 90.0, 200.0, 315.0):
        pixel, ok = project(lens, direction(fov / 2.0, phi))
        assert ok[0], phi
        assert np.linalg.norm(pixel[0] - centre) == pytest.approx(rim, abs=1e-6)
        _, beyond = project(lens, direction(fov / 2.0 + 0.5, phi))
        assert not beyond[0], "a direction outside the field must not be valid"


def test_pixels_outside_the_image_circle_see_nothing() -> None:
    lens = LensModel.create("equidistant", 640, 480, 180.0)
    directions, ok = unproject(lens, pixel_grid(lens))
    u, v = pixel_grid(lens).T
    inside = np.hypot(u - 319.5, v - 239.5) <= 240.0
    np.testing.assert_array_equal(ok, inside)
    assert np.isnan(directions[~ok]).all()
    # The corners and the side bands of a landscape image are outside the circle.
    assert not ok[0] and not ok[639] and not ok[-1]
    assert ok[240 * 640 + 320]


def test_pinhole_rejects_directions_at_or_behind_90_degrees() -> None:
    lens = LensModel.create("pinhole", 640, 480, 170.0)
    pixels, ok = project(lens, np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, 0.2, -1.0], [0.0, 0.0, -1.0]]))
    assert not ok.any()
    assert np.isnan(pixels).all()
    # Just inside 90 degrees the direction is valid only if it lands in the image: 85 degrees across the
    # width's 170-degree field is on its edge, 89 degrees is beyond it.
    edge, ok_edge = project(lens, direction(85.0, 0.0))
    assert ok_edge[0]
    assert edge[0, 0] == pytest.approx(639.5, abs=1e-6)
    _, ok_beyond = project(lens, direction(89.0, 0.0))
    assert not ok_beyond[0]


def test_pinhole_fov_spans_the_width() -> None:
    lens = LensModel.create("pinhole", 800, 600, 90.0)
    left, ok_left = project(lens, direction(45.0, 180.0))
    right, ok_right = project(lens, direction(45.0, 0.0))
    assert ok_left[0] and ok_right[0]
    assert left[0, 0] == pytest.approx(-0.5) and right[0, 0] == pytest.approx(799.5)
    # Vertically the same focal length applies (square pixels): 45 degrees down is beyond 600 px.
    _, ok_down = project(lens, direction(45.0, 90.0))
    assert not ok_down[0]


ROUND_TRIP_LENSES = [
    ("equidistant", 320, 320, 180.0),
    ("equidistant", 320, 240, 260.0),
    ("equisolid", 320, 320, 190.0),
    ("stereographic", 240, 320, 220.0),
    ("pinhole", 320, 240, 100.0),
]


@pytest.mark.parametrize(("model", "width", "height", "fov"), ROUND_TRIP_LENSES)
def test_project_after_unproject_is_the_identity(model: str, width: int, height: int, fov: float) -> None:
    lens = LensModel.create(model, width, height, fov)
    pixels = pixel_grid(lens)
    directions, ok = unproject(lens, pixels)
    assert ok.sum() > 0.5 * len(pixels)
    np.testing.assert_allclose(np.linalg.norm(directions[ok], axis=1), 1.0, atol=1e-12)
    again, ok_again = project(lens, directions[ok])
    assert ok_again.all()
    np.testing.assert_allclose(again, pixels[ok], atol=1e-6)


def test_round_trip_for_opencv_fisheye_and_directions() -> None:
    lens = LensModel.create("opencv_fisheye", 1920, 1080, 140.0, FRONT_K, FRONT_D)
    # Subsample the full-resolution grid to keep the test quick.
    pixels = pixel_grid(lens)[::37]
    directions, ok = unproject(lens, pixels)
    again, ok_again = project(lens, directions[ok])
    assert ok_again.all()
    np.testing.assert_allclose(again, pixels[ok], atol=1e-6)
    rng = np.random.default_rng(7)
    theta = rng.uniform(0.0, lens.theta_max, 5000)
    phi = rng.uniform(-math.pi, math.pi, 5000)
    dirs = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    pixels, ok = project(lens, dirs)
    back, ok_back = unproject(lens, pixels[ok])
    assert ok_back.all()
    np.testing.assert_allclose(back, dirs[ok], atol=1e-6)


def test_opencv_fisheye_reference_values() -> None:
    """The opencv_fisheye rows of the table in docs/lenses.md (the rig's front camera)."""
    lens = LensModel.create("opencv_fisheye", 1920, 1080, 140.0, FRONT_K, FRONT_D)
    for theta, u_right in [(0, 987.611), (30, 1390.954), (60, 1777.968)]:
        right, ok = project(lens, direction(theta, 0.0))
        assert ok[0]
        np.testing.assert_allclose(right[0], [u_right, 592.275], atol=1e-3)
    down, ok = project(lens, direction(30.0, 90.0))
    assert ok[0]
    np.testing.assert_allclose(down[0], [987.611, 996.754], atol=1e-3)
    # 60 degrees down would be row 1384.858, below this 1080-row image: not valid.
    _, ok = project(lens, direction(60.0, 90.0))
    assert not ok[0]
    _, ok = project(lens, direction(71.0, 0.0))
    assert not ok[0], "beyond fov / 2 = 70 degrees"


def _rig() -> dict[str, Any]:
    if not CAMERAS_PARAM.exists():
        pytest.skip(f"shared calibration data not found at {CAMERAS_PARAM}")
    # A ROS 2 parameters file: YAML whose cameras sit under <node>: ros__parameters:.
    data = yaml.safe_load(CAMERAS_PARAM.read_text(encoding="utf-8"))
    return {name: node["ros__parameters"] for name, node in data.items()}


@pytest.mark.parametrize("camera", ["frontCamera", "leftCamera", "rightCamera", "rearCamera"])
def test_opencv_fisheye_agrees_with_opencv_on_real_intrinsics(camera: str) -> None:
    cv2 = pytest.importorskip("cv2")
    params = _rig()[camera]
    k = tuple(float(v) for v in params["intrinsic_matrix"])
    d = tuple(float(v) for v in params["distortion_coefficients"])
    fov = math.degrees(float(params["field_of_view_horizontal"]))  # radians in the file
    lens = LensModel.create("opencv_fisheye", int(params["image_width"]), int(params["image_height"]), fov, k, d)
    k_matrix, d_vector = np.array(k).reshape(3, 3), np.array(d)

    rng = np.random.default_rng(11)
    theta = rng.uniform(0.0, lens.theta_max, 3000)
    phi = rng.uniform(-math.pi, math.pi, 3000)
    dirs = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    ours, _ = project(lens, dirs)
    theirs, _ = cv2.fisheye.projectPoints(dirs.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k_matrix, d_vector)
    theirs = theirs.reshape(-1, 2)
    inside = ~np.isnan(ours[:, 0])
    assert inside.sum() > 1500
    assert np.abs(ours[inside] - theirs[inside]).max() < 0.01

    # Inverse: OpenCV undistorts pixels to normalised coordinates (x/z, y/z); with P = K that is pixels of
    # the ideal pinhole camera, where we compare ours.
    pixels = theirs[inside]
    back, ok = unproject(lens, pixels)
    assert ok.all()
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    undistorted = cv2.fisheye.undistortPoints(
        pixels.reshape(-1, 1, 2), k_matrix, d_vector, P=k_matrix, criteria=criteria
    )
    ideal = np.stack([lens.fx * back[:, 0] / back[:, 2] + lens.cx, lens.fy * back[:, 1] / back[:, 2] + lens.cy], axis=1)
    assert np.abs(ideal - undistorted.reshape(-1, 2)).max() < 0.01


def test_fisheye_field_stops_where_the_polynomial_folds() -> None:
    # k1 = -0.3: theta (1 - 0.3 theta^2) peaks at theta = 1/sqrt(0.9) = 1.054 rad (60.4 degrees).
    k = (300.0, 0.0, 319.5, 0.0, 300.0, 319.5, 0.0, 0.0, 1.0)
    lens = LensModel.create("opencv_fisheye", 640, 640, 200.0, k, (-0.3, 0.0, 0.0, 0.0))
    assert lens.theta_max == pytest.approx(1.0 / math.sqrt(0.9))
    _, ok = project(lens, np.vstack([direction(59.0), direction(62.0)]))
    assert ok.tolist() == [True, False]
    peak = 300.0 * lens.theta_max * (1.0 - 0.3 * lens.theta_max**2)
    _, ok = unproject(lens, np.array([[319.5 + peak - 1.0, 319.5], [319.5 + peak + 1.0, 319.5]]))
    assert ok.tolist() == [True, False]


def test_resized_fisheye_sees_the_same_directions_at_scaled_pixels() -> None:
    full = LensModel.create("opencv_fisheye", 1920, 1080, 140.0, FRONT_K, FRONT_D)
    half = full.resized(960, 540)
    dirs = np.vstack([direction(t, p) for t in (0.0, 20.0, 45.0, 65.0) for p in (0.0, 100.0, 250.0)])
    big, ok_big = project(full, dirs)
    small, ok_small = project(half, dirs)
    np.testing.assert_array_equal(ok_big, ok_small)
    # Pixel centres stay aligned: u' = (u + 0.5) / 2 - 0.5.
    np.testing.assert_allclose(small[ok_small], (big[ok_big] + 0.5) / 2.0 - 0.5, atol=1e-9)
    circle = LensModel.create("equisolid", 640, 640, 190.0).resized(320, 320)
    assert circle == LensModel.create("equisolid", 320, 320, 190.0)


def test_from_config_uses_the_robots_yaml_lens() -> None:
    lens = LensModel.from_config(Lens("opencv_fisheye", 140.0, FRONT_K, FRONT_D), 1920, 1080)
    assert (lens.fx, lens.fy, lens.cx, lens.cy) == (FRONT_K[0], FRONT_K[4], FRONT_K[2], FRONT_K[5])
    assert lens.d == FRONT_D and lens.k == FRONT_K
    assert LensModel.from_config(Lens("equidistant", 180.0), 640, 640) == LensModel.create(
        "equidistant", 640, 640, 180.0
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("fisheye", 640, 640, 180.0), "unknown lens model"),
        (("equidistant", 0, 640, 180.0), "at least 1x1"),
        (("equidistant", 640, 640, 360.0), "between 0 and 360"),
        (("pinhole", 640, 640, 180.0), "between 0 and 180"),
        (("equisolid", 640, 640, float("nan")), "between 0 and 360"),
        (("opencv_fisheye", 640, 640, 180.0), "needs K"),
    ],
)
def test_bad_lenses_are_refused_with_a_reason(args: tuple[Any, ...], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        LensModel.create(*args)


def test_skewed_intrinsics_are_refused() -> None:
    skewed = (300.0, 2.0, 320.0, 0.0, 300.0, 320.0, 0.0, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"\[fx 0 cx; 0 fy cy; 0 0 1\]"):
        LensModel.create("opencv_fisheye", 640, 640, 180.0, skewed, (0.0, 0.0, 0.0, 0.0))


def test_bad_directions_and_pixels_are_invalid_not_errors() -> None:
    lens = LensModel.create("equidistant", 100, 100, 180.0)
    pixels, ok = project(lens, np.array([[0.0, 0.0, 0.0], [np.nan, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, 5.0]]))
    assert ok.tolist() == [False, False, False, True]
    np.testing.assert_allclose(pixels[3], [49.5, 49.5])
    _, ok = unproject(lens, np.array([[np.inf, 3.0], [-1.0, 50.0], [49.5, 49.5]]))
    assert ok.tolist() == [False, False, True]
