"""Camera lens models: where a direction lands in the image, and which direction a pixel sees.

Pure numpy, no I/O, vectorised over arrays, safe to call from any thread. The browser client mirrors these
formulas in JavaScript for the hemisphere screen, so they are spelled out here (and in docs/lenses.md, with a
table of reference values that the tests pin).

Conventions
-----------
* **Camera frame** (OpenCV's optical frame, ROS ``*_optical_frame``): +z forward along the optical axis,
  +x right, +y down. Directions need not be unit length; they must be finite and non-zero.
* **Pixels** follow OpenCV: ``u`` to the right, ``v`` down, the *centre* of the top-left pixel is (0, 0), so a
  ``width`` x ``height`` image spans ``[-0.5, width - 0.5] x [-0.5, height - 0.5]``. A texture coordinate is
  ``s = (u + 0.5) / width``, ``t = (v + 0.5) / height`` (t measured downwards).
* ``theta`` is the angle between a direction and the optical axis, ``phi`` its azimuth around it::

      theta = atan2(hypot(x, y), z)            (0 .. pi)
      (cos phi, sin phi) = (x, y) / hypot(x, y)

Every model maps ``theta`` to a *normalised radius* ``rho = g(theta)``; the pixel is then::

      u = cx + fx * rho * cos(phi)
      v = cy + fy * rho * sin(phi)

and the inverse takes ``mx = (u - cx) / fx``, ``my = (v - cy) / fy``, ``rho = hypot(mx, my)``,
``theta = g^-1(rho)`` and returns the unit direction
``(sin(theta) * mx / rho, sin(theta) * my / rho, cos(theta))`` (``(0, 0, 1)`` at ``rho = 0``).

Models (``fov`` in degrees; ``half = fov / 2`` in radians)
----------------------------------------------------------
============== =============================================== =================================
model          g(theta) = rho                                  focal length (fx = fy = f)
============== =============================================== =================================
equidistant    theta                                           f = R / half
equisolid      2 sin(theta / 2)                                f = R / (2 sin(half / 2))
stereographic  2 tan(theta / 2)                                f = R / (2 tan(half / 2))
pinhole        tan(theta)                                      f = (width / 2) / tan(half)
opencv_fisheye theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8)   fx, fy, cx, cy from K (t = theta)
============== =============================================== =================================

* **Circle models** (equidistant, equisolid, stereographic): the image circle is centred on the image,
  ``cx = (width - 1) / 2``, ``cy = (height - 1) / 2``, with diameter ``min(width, height)``, i.e. radius
  ``R = min(width, height) / 2`` pixels. The optical axis is the image centre and ``theta = fov / 2`` falls
  exactly on the rim of the circle; ``fov`` may exceed 180 (up to, not including, 360).
* **pinhole**: ``fov`` is the horizontal field of view across the full image width (below 180); square
  pixels, centred principal point. Directions with ``theta >= 90`` degrees have no image.
* **opencv_fisheye**: OpenCV's fisheye model (``cv2.fisheye``), ``K = [fx 0 cx; 0 fy cy; 0 0 1]`` in pixels of
  this image, ``D = (k1, k2, k3, k4)``. For ``theta < 90`` degrees it equals ``cv2.fisheye.projectPoints``
  (which computes ``theta = atan(hypot(x/z, y/z))``); computing ``theta`` with atan2 also lets it describe
  lenses wider than 180 degrees. ``fov`` bounds the field as ``theta <= fov / 2``; the field also stops where
  the polynomial stops increasing (beyond it two angles would share a pixel). The inverse solves
  ``g(theta) = rho`` by Newton's method from ``theta = rho``.

Validity
--------
The field ends at ``theta_max``: ``half`` for the circle models, ``min(half, fold)`` for opencv_fisheye
(``fold`` = the first angle where g stops increasing, else 180 degrees), and 90 degrees (exclusive) for
pinhole, whose field is otherwise bounded by the image rectangle. ``project`` and ``unproject`` return a
boolean mask next to their results. An entry is valid when the direction lies inside the field *and*
its pixel lies inside the image rectangle. Invalid entries hold NaN. For the circle models the whole field
is inside the image, so "valid" means "inside the image circle"; pixels outside it see nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..config import LENS_MODELS, Lens

__all__ = [
    "CIRCLE_MODELS",
    "LENS_MODELS",
    "LensModel",
    "angle_of_radius",
    "pixel_grid",
    "project",
    "radius_of_angle",
    "unproject",
]

#: Models whose field is a circle inscribed in the image, sized by ``fov``.
CIRCLE_MODELS = ("equidistant", "equisolid", "stereographic")

# Rounding slack when comparing against the rim of the field and the image edge, so that a direction at
# exactly fov / 2 (or a pixel exactly on the border) counts as inside despite floating-point error.
_ANGLE_SLACK = 1e-9
_PIXEL_SLACK = 1e-6
# Newton's method for the fisheye inverse: the polynomial is smooth and monotonic on the field, so this
# converges quadratically; the cap only guards against pathological coefficients.
_NEWTON_ITERATIONS = 30
_NEWTON_TOLERANCE = 1e-14

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class LensModel:
    """A lens fitted to an image of ``width`` x ``height`` pixels (immutable, hashable).

    Build it with :meth:`create` or :meth:`from_config`, which derive the intrinsics; the fields are the
    resolved values the formulas of this module use. ``theta_max`` (radians) is the edge of the field
    (see "Validity" in the module docstring).
    """

    model: str
    width: int
    height: int
    fov: float  # degrees, as configured
    fx: float
    fy: float
    cx: float
    cy: float
    theta_max: float
    d: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    @classmethod
    def create(
        cls,
        model: str,
        width: int,
        height: int,
        fov: float,
        k: tuple[float, ...] | None = None,
        d: tuple[float, ...] | None = None,
    ) -> LensModel:
        """Resolve a lens for an image size.

        ``k`` (9 numbers, row-major) and ``d`` (4 numbers) are required for, and only used by,
        ``opencv_fisheye``; ``k`` must be in pixels of *this* image size (see :meth:`resized`).
        Raises ``ValueError`` for an unknown model, a size below one pixel, ``fov`` outside
        ``(0, 360)`` (``(0, 180)`` for pinhole), or a ``K`` with skew or a bottom row other than ``0 0 1``
        (OpenCV's fisheye functions ignore both, so accepting them would silently disagree with OpenCV).
        """
        if model not in LENS_MODELS:
            raise ValueError(f"unknown lens model {model!r}; expected one of {', '.join(LENS_MODELS)}")
        if width < 1 or height < 1:
            raise ValueError(f"image size must be at least 1x1 pixels, got {width}x{height}")
        limit = 180.0 if model == "pinhole" else 360.0
        if not (math.isfinite(fov) and 0.0 < fov < limit):
            raise ValueError(f"{model} fov must be in degrees between 0 and {limit:g} (exclusive), got {fov!r}")
        half = math.radians(fov) / 2.0
        cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
        if model == "opencv_fisheye":
            if k is None or d is None or len(k) != 9 or len(d) != 4:
                raise ValueError("opencv_fisheye needs K (9 numbers, row-major) and D (4 numbers)")
            if k[1] != 0.0 or k[3] != 0.0 or (k[6], k[7], k[8]) != (0.0, 0.0, 1.0):
                raise ValueError(f"opencv_fisheye K must be [fx 0 cx; 0 fy cy; 0 0 1], got {list(k)}")
            if not (k[0] > 0.0 and k[4] > 0.0):
                raise ValueError(f"opencv_fisheye K needs positive focal lengths, got fx={k[0]} fy={k[4]}")
            dist = (float(d[0]), float(d[1]), float(d[2]), float(d[3]))
            return cls(model, width, height, fov, k[0], k[4], k[2], k[5], min(half, _fisheye_fold(dist)), dist)
        if model == "pinhole":
            f = (width / 2.0) / math.tan(half)
            # The field is the image rectangle; theta_max only records the axis limit (exclusive).
            return cls(model, width, height, fov, f, f, cx, cy, math.pi / 2.0)
        radius = min(width, height) / 2.0
        f = radius / float(_rho(model, half, (0.0, 0.0, 0.0, 0.0)))
        return cls(model, width, height, fov, f, f, cx, cy, half)

    @classmethod
    def from_config(cls, lens: Lens, width: int, height: int) -> LensModel:
        """The lens of a robots.yaml camera (``relay.config.Lens``) for an image of ``width`` x ``height``."""
        return cls.create(lens.model, width, height, lens.fov, lens.k, lens.d)

    def resized(self, width: int, height: int) -> LensModel:
        """The same lens for an image scaled to ``width`` x ``height`` (e.g. a lower-resolution stream).

        Circle and pinhole models are re-derived from ``fov``. For ``opencv_fisheye`` the intrinsics scale
        with the image, keeping pixel centres aligned: ``f' = f * s`` and ``c' = (c + 0.5) * s - 0.5``.
        """
        if self.model != "opencv_fisheye":
            return LensModel.create(self.model, width, height, self.fov)
        sx, sy = width / self.width, height / self.height
        k = (
            self.fx * sx,
            0.0,
            (self.cx + 0.5) * sx - 0.5,
            0.0,
            self.fy * sy,
            (self.cy + 0.5) * sy - 0.5,
            0.0,
            0.0,
            1.0,
        )
        return LensModel.create(self.model, width, height, self.fov, k, self.d)

    @property
    def k(self) -> tuple[float, ...]:
        """The 3x3 intrinsic matrix, row-major (what OpenCV calls K)."""
        return (self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)


def _poly(theta: FloatArray | float, d: tuple[float, float, float, float]) -> FloatArray | float:
    t2 = theta * theta
    return 1.0 + t2 * (d[0] + t2 * (d[1] + t2 * (d[2] + t2 * d[3])))


def _poly_derivative(theta: FloatArray | float, d: tuple[float, float, float, float]) -> FloatArray | float:
    # d/dtheta of theta * (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8)
    t2 = theta * theta
    return 1.0 + t2 * (3.0 * d[0] + t2 * (5.0 * d[1] + t2 * (7.0 * d[2] + t2 * 9.0 * d[3])))


def _fisheye_fold(d: tuple[float, float, float, float]) -> float:
    """The first angle in (0, pi] where the fisheye polynomial stops increasing, else pi.

    The derivative is a quartic in s = theta^2: 9 k4 s^4 + 7 k3 s^3 + 5 k2 s^2 + 3 k1 s + 1.
    """
    roots = np.roots([9.0 * d[3], 7.0 * d[2], 5.0 * d[1], 3.0 * d[0], 1.0])
    real = roots[np.abs(roots.imag) < 1e-12].real
    positive = real[(real > 0.0) & (real <= math.pi**2)]
    return float(np.sqrt(positive.min())) if positive.size else math.pi


def _rho(model: str, theta: FloatArray | float, d: tuple[float, float, float, float]) -> FloatArray | float:
    """g(theta) of the module docstring; NaN where the model has no image (pinhole at 90 degrees or more)."""
    if model == "equidistant":
        return theta
    if model == "equisolid":
        return 2.0 * np.sin(theta / 2.0)
    if model == "stereographic":
        return 2.0 * np.tan(theta / 2.0)
    if model == "pinhole":
        return np.where(np.asarray(theta) < math.pi / 2.0, np.tan(np.minimum(theta, math.pi / 2.0)), np.nan)
    if model == "opencv_fisheye":
        return theta * _poly(theta, d)
    raise ValueError(f"unknown lens model {model!r}")


def radius_of_angle(lens: LensModel, theta: ArrayLike) -> FloatArray:
    """Normalised radius ``rho = g(theta)`` for angles from the optical axis (radians); pixels = f * rho.

    No field limit is applied here (NaN only where the formula itself has no value).
    """
    with np.errstate(invalid="ignore"):
        return np.asarray(_rho(lens.model, np.asarray(theta, dtype=np.float64), lens.d), dtype=np.float64)


def angle_of_radius(lens: LensModel, rho: ArrayLike) -> FloatArray:
    """The inverse of :func:`radius_of_angle` on the lens's monotonic range; NaN where there is none."""
    r = np.asarray(rho, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        if lens.model == "equidistant":
            return np.where(r >= 0.0, r, np.nan)
        if lens.model == "equisolid":
            return np.where((r >= 0.0) & (r <= 2.0), 2.0 * np.arcsin(np.clip(r / 2.0, 0.0, 1.0)), np.nan)
        if lens.model == "stereographic":
            return np.where(r >= 0.0, 2.0 * np.arctan(r / 2.0), np.nan)
        if lens.model == "pinhole":
            return np.where(r >= 0.0, np.arctan(r), np.nan)
        return _fisheye_inverse(r, lens.d, _fisheye_fold(lens.d))


def _fisheye_inverse(rho: FloatArray, d: tuple[float, float, float, float], fold: float) -> FloatArray:
    """Solve theta * poly(theta) = rho on [0, fold] by Newton's method; NaN beyond the fold's radius."""
    rho_fold = float(fold * _poly(fold, d))
    # Solve for a reachable radius only; radii beyond the fold are marked invalid below. The derivative
    # vanishes at the fold itself, hence the floor on it.
    target = np.clip(rho, 0.0, rho_fold)
    theta = np.clip(target, 0.0, fold)
    for _ in range(_NEWTON_ITERATIONS):
        slope = np.maximum(_poly_derivative(theta, d), 1e-12)
        step = (theta * _poly(theta, d) - target) / slope
        theta = np.clip(theta - step, 0.0, fold)
        if not np.any(np.abs(step) > _NEWTON_TOLERANCE):
            break
    ok = (rho >= 0.0) & (rho <= rho_fold * (1.0 + 1e-12))
    return np.where(ok, theta, np.nan)


def _inside_image(lens: LensModel, u: FloatArray, v: FloatArray) -> BoolArray:
    lo = -0.5 - _PIXEL_SLACK
    return (u >= lo) & (u <= lens.width - 0.5 + _PIXEL_SLACK) & (v >= lo) & (v <= lens.height - 0.5 + _PIXEL_SLACK)


def project(lens: LensModel, directions: ArrayLike) -> tuple[FloatArray, BoolArray]:
    """Pixels ``(N, 2)`` (u, v) of camera-frame ``directions`` ``(N, 3)``, and the valid mask ``(N,)``.

    Valid: a finite non-zero direction inside the lens's field whose pixel lies in the image (see the module
    docstring). Invalid rows are NaN. Directions are not modified.
    """
    dirs = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    x, y, z = dirs[:, 0], dirs[:, 1], dirs[:, 2]
    lateral = np.hypot(x, y)
    theta = np.arctan2(lateral, z)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = np.asarray(_rho(lens.model, theta, lens.d), dtype=np.float64)
        # Azimuth is undefined on the axis; rho is 0 there anyway (and straight behind is never valid).
        cos_phi = np.where(lateral > 0.0, x / lateral, 0.0)
        sin_phi = np.where(lateral > 0.0, y / lateral, 0.0)
    u = lens.cx + lens.fx * rho * cos_phi
    v = lens.cy + lens.fy * rho * sin_phi
    finite = np.isfinite(dirs).all(axis=1) & ((lateral > 0.0) | (z > 0.0))
    # pinhole: the axis limit is exclusive (tan diverges); its field is otherwise the image rectangle.
    in_field = theta < math.pi / 2.0 if lens.model == "pinhole" else theta <= lens.theta_max + _ANGLE_SLACK
    valid = finite & in_field & np.isfinite(u) & np.isfinite(v) & _inside_image(lens, u, v)
    pixels = np.stack([u, v], axis=1)
    pixels[~valid] = np.nan
    return pixels, valid


def unproject(lens: LensModel, pixels: ArrayLike) -> tuple[FloatArray, BoolArray]:
    """Unit camera-frame directions ``(N, 3)`` seen by ``pixels`` ``(N, 2)`` (u, v), and the valid mask ``(N,)``.

    Valid: a finite pixel inside the image whose direction lies inside the lens's field. Invalid rows are NaN.
    ``project(lens, unproject(lens, p)[0])`` returns ``p`` for every valid ``p``.
    """
    px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    u, v = px[:, 0], px[:, 1]
    mx = (u - lens.cx) / lens.fx
    my = (v - lens.cy) / lens.fy
    rho = np.hypot(mx, my)
    theta = angle_of_radius(lens, rho)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(rho > 0.0, np.sin(theta) / rho, 0.0)
        dirs = np.stack([mx * scale, my * scale, np.cos(theta)], axis=1)
    in_field = theta < math.pi / 2.0 if lens.model == "pinhole" else theta <= lens.theta_max + _ANGLE_SLACK
    valid = np.isfinite(px).all(axis=1) & np.isfinite(theta) & in_field & _inside_image(lens, u, v)
    dirs[~valid] = np.nan
    return dirs, valid


def pixel_grid(lens: LensModel) -> FloatArray:
    """Every pixel centre of the image, ``(height * width, 2)`` (u, v), in row-major order (row = v)."""
    v, u = np.mgrid[0 : lens.height, 0 : lens.width]
    return np.stack([u.ravel(), v.ravel()], axis=1).astype(np.float64)
