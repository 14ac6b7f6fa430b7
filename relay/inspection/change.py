"""What changed at a target between two of its captures: the earlier image aligned onto the later one, a change map
and a change score. Pure (images in, numbers and a mask out): no I/O, no clock; the caller runs it off the loop.

A mission's robot inspects a target from the same standoff pose each round, so two captures differ by a small shift
of the view and by whatever changed at the place. The earlier image is aligned to the later one with OpenCV: ORB
features matched both ways and a homography by RANSAC (robust to the changed part, which has no match), refined by
ECC on the intensities; when too few features match (a bare wall), ECC alone from the identity. The change map is
where the aligned images differ in colour by more than the noise of the scene (both images blurred, the difference
in CIE Lab so that a shadow's lightness weighs less than a new colour, thresholded, small specks opened away). The
score is the changed share of the part both images see.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final

import cv2
import numpy as np
from numpy.typing import NDArray

#: Longest side images are compared at, pixels: a comparison at 640 px took 0.6-1.7 s here (most of it ECC's
#: refinement), once per target and round, on the planning pool; full resolution adds nothing a finding needs.
WORK_SIZE: Final = 640
#: A pixel has changed when its colour moved by more than this in CIE Lab (Delta E 1976 on 8-bit Lab, lightness at
#: half weight). At 20 a dark green spill over a grey shutter was missed in half; the real photographs moved a few
#: percent and nothing changed score 0.0 at 15.
COLOUR_THRESHOLD: Final = 15.0
#: A target whose changed share is over this gets a ``changed`` finding.
SCORE_THRESHOLD: Final = 0.02
#: Fewest feature matches a homography is trusted from.
MIN_MATCHES: Final = 12


#: An 8-bit image (BGR, or a mask) as OpenCV hands it back.
Image = NDArray[Any]


class ChangeError(ValueError):
    """Two captures that cannot be compared (unreadable, empty, or too small); the message says which and why."""


@dataclass(frozen=True)
class Change:
    """The later capture against the earlier: ``score`` the changed share of what both see (0-1), ``mask`` 255 where
    the place changed (at the later image's working size), ``aligned`` how the earlier image was put onto it
    (``features``, ``intensity`` or ``none``) and ``homography`` the 3x3 that did it (earlier -> later, working
    size)."""

    score: float
    mask: Image
    aligned: str
    homography: NDArray[np.float64]

    @property
    def changed(self) -> bool:
        return self.score > SCORE_THRESHOLD

    def box(self) -> tuple[float, float, float, float] | None:
        """Where the change is, as (u0, v0, u1, v1) fractions of the image, or None when nothing changed."""
        rows = np.flatnonzero(self.mask.any(axis=1))
        cols = np.flatnonzero(self.mask.any(axis=0))
        if rows.size == 0:
            return None
        h, w = self.mask.shape
        return (cols[0] / w, rows[0] / h, (cols[-1] + 1) / w, (rows[-1] + 1) / h)


def decode(jpeg: bytes, what: str) -> Image:
    """A JPEG or PNG as a BGR image; ChangeError naming ``what`` when it is not one."""
    image = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    if image is None or image.size == 0:
        raise ChangeError(f"{what}: not an image OpenCV can read")
    return np.asarray(image, dtype=np.uint8)


def compare(earlier: Image, later: Image) -> Change:
    """The change from ``earlier`` to ``later`` (BGR images; sizes may differ: both are brought to WORK_SIZE)."""
    a, b = _working(earlier, "the earlier capture"), _working(later, "the later capture")
    if a.shape != b.shape:
        a = cv2.resize(a, (b.shape[1], b.shape[0]), interpolation=cv2.INTER_AREA)
    homography, how = _align(a, b)
    h, w = b.shape[:2]
    warped = cv2.warpPerspective(a, homography, (w, h), flags=cv2.INTER_LINEAR)
    seen = cv2.warpPerspective(np.full((h, w), 255, np.uint8), homography, (w, h), flags=cv2.INTER_NEAREST)
    seen = cv2.erode(seen, np.ones((5, 5), np.uint8))  # the warped border is a blend with black: not a change
    mask = _difference(warped, b) & seen
    area = int(np.count_nonzero(seen))
    score = float(np.count_nonzero(mask)) / area if area else 0.0
    return Change(score, mask, how, homography)


def _working(image: Image, what: str) -> Image:
    if image.ndim != 3 or image.shape[2] != 3 or min(image.shape[:2]) < 32:
        raise ChangeError(f"{what}: a colour image of at least 32x32 pixels is needed, got shape {image.shape}")
    scale = WORK_SIZE / max(image.shape[:2])
    if scale >= 1.0:
        return image
    size = (round(image.shape[1] * scale), round(image.shape[0] * scale))
    return np.asarray(cv2.resize(image, size, interpolation=cv2.INTER_AREA), dtype=np.uint8)


def _align(a: Image, b: Image) -> tuple[NDArray[np.float64], str]:
    """The homography taking ``a`` onto ``b``, and how it was found."""
    ga, gb = cv2.cvtColor(a, cv2.COLOR_BGR2GRAY), cv2.cvtColor(b, cv2.COLOR_BGR2GRAY)
    start, how = _features(ga, gb), "features"
    if start is None:
        start, how = np.eye(3), "intensity"
    warp = start.astype(np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 60, 1e-5)
    try:
        # ECC maps the template (b) onto the input (a): its warp is b -> a; the map wanted is a -> b.
        _, refined = cv2.findTransformECC(
            cv2.GaussianBlur(gb, (5, 5), 0), cv2.GaussianBlur(ga, (5, 5), 0), np.linalg.inv(warp).astype(np.float32),
            cv2.MOTION_HOMOGRAPHY, criteria, None,
        )  # fmt: skip
        return np.linalg.inv(np.asarray(refined, dtype=np.float64)), how
    except cv2.error:
        # ECC did not converge (too little texture, or too different): the features' homography, else none.
        return (start.astype(np.float64), how) if how == "features" else (np.eye(3), "none")


def _features(ga: Image, gb: Image) -> NDArray[np.float64] | None:
    orb = cv2.ORB.create(nfeatures=1500)
    ka, da = orb.detectAndCompute(ga, None)
    kb, db = orb.detectAndCompute(gb, None)
    if da is None or db is None or len(ka) < MIN_MATCHES or len(kb) < MIN_MATCHES:
        return None
    matches = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(da, db)
    if len(matches) < MIN_MATCHES:
        return None
    src = np.array([ka[m.queryIdx].pt for m in matches], np.float32)
    dst = np.array([kb[m.trainIdx].pt for m in matches], np.float32)
    homography, inliers = cv2.findHomography(src, dst, cv2.RANSAC, 3.0)
    if homography is None or int(inliers.sum()) < MIN_MATCHES:
        return None
    return np.asarray(homography, dtype=np.float64)


def _difference(a: Image, b: Image) -> Image:
    """255 where the two aligned images differ in colour beyond the scene's noise."""
    la = cv2.cvtColor(cv2.GaussianBlur(a, (7, 7), 0), cv2.COLOR_BGR2LAB).astype(np.float32)
    lb = cv2.cvtColor(cv2.GaussianBlur(b, (7, 7), 0), cv2.COLOR_BGR2LAB).astype(np.float32)
    delta = la - lb
    delta[..., 0] *= 0.5  # lightness alone (a shadow, the exposure) weighs half as much as a change of colour
    distance = np.sqrt((delta * delta).sum(axis=2))
    mask = np.where(distance > COLOUR_THRESHOLD, 255, 0).astype(np.uint8)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
    return np.asarray(cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel), dtype=np.uint8)
