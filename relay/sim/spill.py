"""The chemical spill that grows: its outline at a time, and the gas it gives off (pure; time is passed in).

The twin draws the spill as the :class:`~relay.sim.floorplan.Decal` ``spill`` with a roughened edge
(:func:`~relay.sim.floorplan.edge_radius`). Grown by a scale ``s`` (robots.yaml ``sim.spill_growth``,
:class:`relay.config.SpillGrowth`), the outline is that same roughened outline scaled by ``s`` about the decal's
centre; the simulated camera paints the floor inside it in the spill's colour (relay/sim/camera.py), and the gas
sources under the spill spread with it. :meth:`GrownSpill.contains` is the simulator's truth of where the spill is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .floorplan import EDGE_SEGMENTS, Decal, edge_radius
from .hazards import HazardSource

__all__ = ["GrownSpill", "SpillPainter", "grow_sources"]


@dataclass(frozen=True)
class GrownSpill:
    """The spill ``decal`` (its first, nominal outline) grown ``scale`` times (>= 1) about its centre."""

    decal: Decal
    scale: float = 1.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.scale) and self.scale >= 1.0):
            raise ValueError(f"a spill grows by a scale >= 1, got {self.scale!r}")

    @property
    def outline(self) -> Decal:
        """The nominal ellipse of the grown spill, map frame (its edge is roughened as the decal's)."""
        return replace(self.decal, radius_x=self.decal.radius_x * self.scale, radius_y=self.decal.radius_y * self.scale)

    def contains(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """Whether each map point ``(x, y)`` lies inside the grown outline (vectorised): the twin's own outline
        (relay/twin/facility_glb.py), scaled.

        In the ellipse's normalised coordinates ``(u / radius_x, v / radius_y)`` the twin's outline is a polygon
        star-shaped about the centre, with a vertex at ``edge_radius(t_i)`` every ``tau / EDGE_SEGMENTS`` of polar
        angle (the normalisation is linear, so straight edges stay straight): a point at polar angle ``t`` and
        distance ``rho`` is inside when ``rho`` is at most the distance of the edge between the vertices around
        ``t``. At a scale just over 1 it is the twin's mesh, so growth starts from what the camera showed.
        """
        d = self.outline
        # float32 points stay float32 (micrometres at a facility's scale), floats become float64.
        dx = np.asarray(x) - d.x
        dy = np.asarray(y) - d.y
        # Only points within the outline's bounding circle get the trigonometry: a camera's floor hits are tens
        # of thousands, those near the spill a few thousand (render cost: see SpillPainter.grow).
        reach = max(d.radius_x, d.radius_y) * float(_VERTEX_RADII.max())
        out: NDArray[np.bool_] = dx * dx + dy * dy <= reach * reach
        near = np.flatnonzero(out)
        dx, dy = dx.reshape(-1)[near], dy.reshape(-1)[near]
        c, s = math.cos(d.angle), math.sin(d.angle)
        u = (c * dx + s * dy) / d.radius_x
        v = (-s * dx + c * dy) / d.radius_y
        t = np.arctan2(v, u) % math.tau
        i = np.minimum((t // _STEP).astype(np.intp), EDGE_SEGMENTS - 1)
        r0, r1 = _VERTEX_RADII[i], _VERTEX_RADII[i + 1]
        after = t - i * _STEP
        # The distance along the ray at angle t to the line through r0 at t_i and r1 at t_i + step.
        edge = r0 * r1 * math.sin(_STEP) / (r0 * np.sin(after) + r1 * np.sin(_STEP - after))
        out.reshape(-1)[near] = np.hypot(u, v) <= edge
        return out


_STEP = math.tau / EDGE_SEGMENTS
# The twin's vertex radii, computed as it computes them, the first repeated at the end (the polygon closes).
_VERTEX_RADII = np.array(
    [edge_radius(math.tau * (i % EDGE_SEGMENTS) / EDGE_SEGMENTS) for i in range(EDGE_SEGMENTS + 1)]
)
_VERTEX_RADII.setflags(write=False)


def grow_sources(sources: tuple[HazardSource, ...], spill: GrownSpill) -> tuple[HazardSource, ...]:
    """``sources`` with the gas sources under the spill's first outline spread with it: ``sigma`` and ``peak``
    times the scale (a wider pool evaporates over a wider area; the peak grows with the radius, not the area, so
    the demo's 800 ppm stays below 2000 ppm at the default limit 2). Other sources are returned unchanged."""
    if spill.scale == 1.0:
        return sources
    first = GrownSpill(spill.decal)
    return tuple(
        replace(h, peak=h.peak * spill.scale, sigma=h.sigma * spill.scale)
        if h.kind == "gas" and bool(first.contains(h.x, h.y))
        else h
        for h in sources
    )


class SpillPainter:
    """Turns a camera's hits on the floor under a grown spill into hits on the spill's mesh, which shade in its
    colour (facing up, 4 mm above the floor): the camera's picture of the spill as it has grown.

    ``floor`` and ``spill`` mark the scene's faces of each (relay/sim/camera.py's ``faces_under``); ``planes`` is
    each face's unit normal and plane offset ``n.v0`` (F, 4), from which a hit's distance follows. A scene
    without a spill mesh paints nothing.
    """

    def __init__(self, floor: NDArray[np.bool_], spill: NDArray[np.bool_], planes: NDArray[np.float32]) -> None:
        self._floor, self._spill, self._planes = floor, spill, planes
        faces = np.flatnonzero(spill)
        self._spill_face = int(faces[0]) if len(faces) else None

    def grow(
        self,
        hits: NDArray[np.int64],
        directions: NDArray[np.float32],
        origin: NDArray[np.float64],
        spill: GrownSpill | None,
    ) -> NDArray[np.int64]:
        """``hits`` (face per ray, negative: none) with the floor inside ``spill``'s outline seen as the spill: a
        copy, or ``hits`` itself when nothing grows.

        Cost (relay/sim/camera.py's budget): 58 000-82 000 of the 181 000 rays of a 480x480 equidistant frame hit
        the floor; finding where, and testing the few thousand near the spill against the outline, took 7.5-13.5 ms
        of the rendering thread's CPU (medians of 60; minimum 5.8) on the 2-core machine while other jobs loaded it
        (load average 15-16). Renders along the benchmark's drive to the spill: 74.5 ms of CPU (median of 30)
        without growth, 89-91 ms grown; at 320x320 35 ms, 40-41 ms grown.
        """
        if spill is None or spill.scale == 1.0 or self._spill_face is None:
            return hits
        floor = np.flatnonzero(self._floor[np.maximum(hits, 0)] & (hits >= 0))
        planes, d = self._planes[hits[floor]], directions[floor]
        n_dot_d = np.einsum("ij,ij->i", planes[:, 0:3], d)
        origin32 = origin.astype(np.float32)
        t = (planes[:, 3] - planes[:, 0:3] @ origin32) / np.where(n_dot_d == 0.0, 1e-12, n_dot_d)
        points = origin32[None, :2] + t[:, None] * d[:, :2]
        out = hits.copy()
        out[floor[spill.contains(points[:, 0], points[:, 1])]] = self._spill_face
        return out

    def covers(self, faces: NDArray[np.int64]) -> NDArray[np.bool_]:
        """True where ``faces`` (a camera's trace, grown) are the spill's."""
        out: NDArray[np.bool_] = (faces >= 0) & self._spill[np.maximum(faces, 0)]
        return out
