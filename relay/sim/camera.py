"""The simulated wide-angle camera: the facility twin seen through a lens model, by ray casting.

A :class:`SimCamera` is built once from the twin (``scenes/facility.glb``, glTF Y-up, PBR base colours) and
then renders any robot pose through any :class:`~relay.media.lens.LensModel`: one ray per pixel, cast all at once
against the whole scene (Embree through ``embreex`` when it imports, else trimesh's pure triangle
intersector), and shaded flatly per face. It is the picture a robot's camera would show, good enough to
recognise the spill, the panels and the puddle on the operator's hemisphere screen; it is not a
photorealistic renderer (no shadows, no reflections, no textures beyond their mean colour).

Frames (REP 103 and REP 105)
----------------------------
* The scene is converted to ROS Z-up once, with :data:`relay.twin.frames.GLTF_TO_ROS`, and into the map
  frame with the inverse of robots.yaml's ``scene.map_to_scene`` (the identity for the demo facility), so
  ``render`` takes map-frame poses, as the robots report them.
* The camera sits at ``(x, y, height)`` on the robot and looks along the robot's +x. ``yaw`` turns it
  counter-clockwise about +z; ``pitch`` is a right-handed rotation about the robot's +y, so a positive pitch
  tilts it *down* (REP 103). Rays are generated in OpenCV's optical frame (+z forward, +x right, +y down),
  the convention of :mod:`relay.media.lens`.

Shading
-------
Colours are glTF's: a material's ``baseColorFactor`` (times its texture's mean colour, if any) or the
geometry's face colours, all *linear* RGB. A pixel that hits face ``f`` at distance ``t`` along a unit ray
``d`` gets::

    linear = albedo[f] * (AMBIENT + DIFFUSE * max(0, n.L) + HEADLIGHT * |n.d|) / (1 + (t / FALLOFF)^2)

with ``n`` the face normal turned towards the camera (faces are lit from both sides, since twin meshes are
not guaranteed to be closed or consistently wound) and ``L`` a fixed light from above. The headlight term
lights the walls the camera faces, which the overhead light barely touches. The result is encoded to sRGB
as a browser shows the twin, so a surface looks the same in the twin and on the hemisphere. Rays that hit
nothing show :data:`VOID_RGB`; pixels outside the lens's field are black.

Threads and performance
-----------------------
Everything that does not depend on the pose is computed once: per-face colours, normals and plane offsets
at construction, the camera-frame ray of every pixel per lens (cached, behind a lock). ``render`` keeps no
other state, so several threads may render at once; the backend must call it through
``asyncio.to_thread``, never on the event loop. Embree, most of numpy and OpenCV's encoder release the GIL
while they work, so a render in a worker thread leaves the event loop responsive.

Measured on the 2-core development machine (``bench/bench_sim_camera.py``, scenes/facility.glb, 2300 faces,
equidistant 180 degrees, a robot driving towards the spill, medians of 30 frames, Embree). Other jobs shared
the machine (load average 2 to 5), hence ranges; the CPU time of the rendering thread is steadier:

=========  ========================  ==========  ===================  =================
size       render wall (CPU)         JPEG q80    snapshot             stream (1 thread)
=========  ========================  ==========  ===================  =================
320x320    26-35 ms (25-33 ms)       0.5-0.7 ms  26-35 ms, 9 kB       28-38 fps
480x480    63-113 ms (62-102 ms)     1.2-1.8 ms  64-115 ms, 15 kB     9-16 fps
640x640    150-300 ms (120-150 ms)   2-3 ms      150-300 ms, 22 kB    3-6 fps
=========  ========================  ==========  ===================  =================

hence :data:`DEFAULT_SIZE` 480: a snapshot well under 200 ms and a stream of 9 to 16 fps even on a busy
machine; 640 misses the budget as soon as the other core is busy. Two renders in parallel threads run 1.4
times faster than one after the other (Embree's own casts: 1.65 times). The pure-Python fallback intersector
casts only about 4000 rays per second here (48x48: 0.40-0.69 s a frame, 64x64: 0.70 s); it cannot meet the
budget at any useful size, so :data:`FALLBACK_SIZE` is the smallest image that still shows the spill, at
1.5 to 2.5 fps. A spill that has grown (``render``'s ``spill``, relay/sim/spill.py) costs 10-16 ms more CPU at
480x480 (74.5 ms median, 89-91 ms grown, measured at load average 15: wall times then meant nothing).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol

import cv2
import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray

from ..config import Lens
from ..media.imaging import JPEG_QUALITY, encode_jpeg
from ..media.lens import LensModel, pixel_grid, unproject
from .scene_parts import ScenePart, parts_from_scene
from .spill import GrownSpill, SpillPainter

__all__ = [
    "CAMERA_HEIGHT",
    "DEFAULT_SIZE",
    "FALLBACK_SIZE",
    "NO_HIT",
    "OUTSIDE_FIELD",
    "VOID_RGB",
    "Engine",
    "RayGrid",
    "SimCamera",
    "camera_rotation",
    "embree_available",
    "rgb_to_jpeg",
    "spill_mask",
]

logger = logging.getLogger(__name__)

Engine = Literal["auto", "embree", "triangle"]

#: Camera mount height above the floor (m): a TurtleBot-class robot's front camera.
CAMERA_HEIGHT = 0.3
#: Default (largest) square image size with Embree: 480x480 renders in 65-115 ms on 2 cores (module docstring).
DEFAULT_SIZE = 480
#: Largest image size with the pure-Python fallback intersector, nearly a thousand times slower than Embree.
FALLBACK_SIZE = 48
#: sRGB colour of rays that hit nothing (open sky above the walls, beyond a door).
VOID_RGB = (40, 40, 44)
#: Face index of ``trace`` for a pixel whose ray hits nothing.
NO_HIT = -1
#: Face index of ``trace`` for a pixel outside the lens's field (black in the image).
OUTSIDE_FIELD = -2

# Lighting constants (linear RGB gains). Ambient keeps faces turned away from both lights readable;
# DIFFUSE + HEADLIGHT + AMBIENT stay near 1 so the brightest surfaces show their base colour unclipped.
AMBIENT = 0.25
DIFFUSE = 0.45
HEADLIGHT = 0.35
#: Distance (m) at which light has fallen to a half: mild, so the far end of a room is dimmer, not black.
FALLOFF = 12.0
#: Direction *towards* the fixed light, in the scene's ROS frame: high above, slightly from the south-east, so
#: that walls facing different ways get different shades and box edges stay visible.
LIGHT_DIRECTION = (0.3, -0.45, 1.0)

# Optical frame (z forward, x right, y down) to robot base frame (x forward, y left, z up): the columns are
# the optical axes expressed in the base frame.
_BASE_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
# Ray grids kept per camera (each a few MB at 480x480).
_MAX_CACHED_LENSES = 8
# Linear -> sRGB lookup: 4096 steps keep the darkest sRGB codes distinct (the curve is steep near 0).
_LUT_SIZE = 4096


def _srgb_lut() -> NDArray[np.uint8]:
    linear = np.linspace(0.0, 1.0, _LUT_SIZE)
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1.0 / 2.4) - 0.055)
    return np.round(srgb * 255.0).astype(np.uint8)


_SRGB_LUT = _srgb_lut()
_SRGB_LUT.setflags(write=False)


def embree_available() -> bool:
    """True when trimesh's Embree intersector (``embreex``) imports on this machine."""
    try:
        from trimesh.ray import ray_pyembree  # noqa: F401
    except Exception:  # ImportError, or an OSError from a broken native library
        return False
    return True


def camera_rotation(yaw: float, pitch: float = 0.0) -> NDArray[np.float64]:
    """3x3 rotation taking optical-frame vectors to the map frame, for a robot heading ``yaw``.

    ``Rz(yaw) @ Ry(pitch) @ base_from_optical``: the optical axis (+z) points along the robot's +x, tilted
    down by a positive ``pitch`` (radians).
    """
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    out: NDArray[np.float64] = rz @ ry @ _BASE_FROM_OPTICAL
    return out


class _Intersector(Protocol):
    def intersects_first(self, ray_origins: Any, ray_directions: Any) -> NDArray[np.int64]: ...


@dataclass(frozen=True)
class RayGrid:
    """The pose-independent rays of one lens: unit optical-frame directions of the pixels in its field."""

    directions: NDArray[np.float32]  # (M, 3)
    index: NDArray[np.int64]  # (M,) flat pixel index (row-major) of each direction
    height: int
    width: int
    blank: NDArray[np.uint8]  # (height, width, 3): black outside the field, VOID_RGB inside


class SimCamera:
    """Renders the scene through a lens from any robot pose; immutable once built, safe across threads.

    ``parts`` are in the map frame; ``light`` is the direction towards the fixed light in that frame.

    ``engine`` picks the ray intersector: ``"embree"`` (raises ``RuntimeError`` if ``embreex`` does not
    import), ``"triangle"`` (trimesh's pure-Python one), or ``"auto"``: Embree when available. The choice is
    logged and exposed as :attr:`engine`.
    """

    def __init__(
        self, parts: Sequence[ScenePart], *, light: ArrayLike = LIGHT_DIRECTION, engine: Engine = "auto"
    ) -> None:
        parts = [p for p in parts if len(p.faces)]
        if not parts:
            raise ValueError("the scene has no triangles to render")
        offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
        vertices = np.concatenate([p.vertices for p in parts]).astype(np.float64)
        faces = np.concatenate([p.faces + offset for p, offset in zip(parts, offsets, strict=False)])
        self.paths: tuple[tuple[str, ...], ...] = tuple(p.path for p in parts)
        #: Index into :attr:`paths` of each face.
        self.face_part: NDArray[np.int64] = np.repeat(np.arange(len(parts)), [len(p.faces) for p in parts])
        #: Linear RGB base colour of each face, float32 (F, 3).
        self.albedo: NDArray[np.float32] = np.clip(np.concatenate([p.albedo for p in parts]), 0.0, 1.0).astype(
            np.float32
        )
        triangles = vertices[faces]
        normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
        lengths = np.linalg.norm(normals, axis=1, keepdims=True)
        # Degenerate faces keep a zero normal; no ray can hit them anyway.
        normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0.0)
        #: Unit normal of each face (map frame), float64 (F, 3), as wound in the scene.
        self.normals: NDArray[np.float64] = normals
        light = np.asarray(light, dtype=np.float64).reshape(3)
        if not (np.isfinite(light).all() and np.linalg.norm(light) > 0.0):
            raise ValueError(f"light must be a finite non-zero direction, got {light.tolist()}")
        # Everything shading needs per face, in one float32 table so that a render gathers it in one go:
        # normal (3), n.L (1), albedo (3), and the plane offset n.v0 (1), from which a hit's distance follows
        # without computing the hit point: t = (n.v0 - n.origin) / (n.d).
        table = np.empty((len(faces), 8), dtype=np.float32)
        table[:, 0:3] = normals
        table[:, 3] = normals @ (light / np.linalg.norm(light))
        table[:, 4:7] = self.albedo
        table[:, 7] = np.einsum("ij,ij->i", normals, triangles[:, 0])
        self._face_table = table
        for array in (self.face_part, self.albedo, self.normals, self._face_table):
            array.setflags(write=False)
        #: Paints the floor under a grown spill (relay/sim/spill.py) in the spill's colour.
        self.spill_painter = SpillPainter(self.faces_under("floor"), self.faces_under("spill"), table[:, [0, 1, 2, 7]])

        #: The whole scene as one map-frame mesh, faces in the order of :attr:`face_part`. Read it; never modify
        #: it (the per-face tables and the ray engine are built from it once).
        self.mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
        self.engine: str
        self._intersector: _Intersector
        if engine not in ("auto", "embree", "triangle"):
            raise ValueError(f"engine must be auto, embree or triangle, got {engine!r}")
        use_embree = engine != "triangle" and embree_available()
        if engine == "embree" and not use_embree:
            raise RuntimeError("the embree ray engine was requested but embreex does not import on this machine")
        if use_embree:
            from trimesh.ray.ray_pyembree import RayMeshIntersector as EmbreeIntersector

            self._intersector = EmbreeIntersector(self.mesh)
            self.engine = "embree"
        else:
            from trimesh.ray.ray_triangle import RayMeshIntersector as TriangleIntersector

            self._intersector = TriangleIntersector(self.mesh)  # type: ignore[no-untyped-call]
            self.engine = "triangle"
        # The triangle intersector's lazily built trees and caches are not meant for concurrent use, and it
        # holds the GIL anyway: serialise it. Embree queries on a committed scene are thread-safe.
        self._cast_lock: threading.Lock | None = threading.Lock() if self.engine == "triangle" else None
        # Build the engine's acceleration structure now (both build lazily on the first query), so that
        # concurrent renders only ever read it.
        self._intersector.intersects_first(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]))
        self._grids: dict[LensModel, RayGrid] = {}
        self._grids_lock = threading.Lock()
        lo, hi = self.mesh.bounds
        logger.info(
            "sim camera: %d faces in %d parts, bounds (%.1f, %.1f, %.1f)..(%.1f, %.1f, %.1f) m, %s ray engine%s",
            len(faces),
            len(parts),
            *lo,
            *hi,
            self.engine,
            "" if self.engine == "embree" else f" (slow: keep images near {FALLBACK_SIZE}x{FALLBACK_SIZE})",
        )

    # -- construction -----------------------------------------------------------------------------

    @classmethod
    def from_scene(
        cls,
        scene: trimesh.Scene | trimesh.Trimesh,
        *,
        y_up: bool = True,
        map_to_scene: ArrayLike | None = None,
        engine: Engine = "auto",
    ) -> SimCamera:
        """Build from a trimesh scene (see :func:`parts_from_scene` for ``y_up`` and ``map_to_scene``)."""
        parts = parts_from_scene(scene, y_up=y_up, map_to_scene=map_to_scene)
        # The light belongs to the building: it turns with the scene when the map frame is rotated in it.
        light = np.asarray(LIGHT_DIRECTION, dtype=np.float64)
        if map_to_scene is not None:
            light = np.linalg.inv(np.asarray(map_to_scene, dtype=np.float64).reshape(4, 4))[:3, :3] @ light
        return cls(parts, light=light, engine=engine)

    @classmethod
    def load(cls, path: str | Path, *, map_to_scene: ArrayLike | None = None, engine: Engine = "auto") -> SimCamera:
        """Build from a glTF/GLB file (the facility twin), converting glTF Y-up to ROS Z-up.

        ``map_to_scene``: robots.yaml's ``scene.map_to_scene`` as a 4x4 matrix
        (:func:`relay.twin.frames.map_to_scene_matrix`), so that ``render`` takes map-frame poses; None is the
        identity. Raises ``ValueError`` (or trimesh's errors) for a file that is not a scene.
        """
        scene = trimesh.load(str(path), force="scene")
        if not isinstance(scene, trimesh.Scene):  # force="scene" promises one; keep the type checker honest
            raise ValueError(f"{path}: trimesh did not load a scene")
        logger.info("sim camera: loaded %s", path)
        return cls.from_scene(scene, y_up=True, map_to_scene=map_to_scene, engine=engine)

    # -- queries ----------------------------------------------------------------------------------

    @property
    def max_size(self) -> int:
        """Longest image side this camera renders within the frame budget: DEFAULT_SIZE or FALLBACK_SIZE."""
        return DEFAULT_SIZE if self.engine == "embree" else FALLBACK_SIZE

    def fit_lens(self, lens: Lens, width: int, height: int) -> LensModel:
        """The lens of a robots.yaml camera (``width`` x ``height``), scaled down to :attr:`max_size`.

        The aspect ratio is kept and images are never scaled up; an ``opencv_fisheye`` K is rescaled with the
        image (:meth:`LensModel.resized`). The frame header must then carry the returned size.
        """
        configured = LensModel.from_config(lens, width, height)
        scale = min(1.0, self.max_size / max(width, height))
        if scale >= 1.0:
            return configured
        return configured.resized(max(1, round(width * scale)), max(1, round(height * scale)))

    def faces_under(self, name: str) -> NDArray[np.bool_]:
        """Mask over faces: True for faces of the node called ``name`` or of any node below it."""
        part_mask = np.array([name in path for path in self.paths], dtype=np.bool_)
        out: NDArray[np.bool_] = part_mask[self.face_part]
        return out

    def rays(self, lens: LensModel) -> RayGrid:
        """The camera-frame rays of ``lens``'s pixels in its field, computed once per lens (thread-safe)."""
        grid = self._grids.get(lens)
        if grid is not None:
            return grid
        with self._grids_lock:
            grid = self._grids.get(lens)
            if grid is None:
                directions, valid = unproject(lens, pixel_grid(lens))
                index = np.flatnonzero(valid)
                dirs32 = directions[index].astype(np.float32)
                blank = np.zeros((lens.height, lens.width, 3), dtype=np.uint8)
                blank.reshape(-1, 3)[index] = VOID_RGB
                for array in (dirs32, index, blank):
                    array.setflags(write=False)
                grid = RayGrid(dirs32, index, lens.height, lens.width, blank)
                if len(self._grids) >= _MAX_CACHED_LENSES:
                    # A few cameras per fleet is the norm; a caller cycling through sizes must not grow this.
                    self._grids.pop(next(iter(self._grids)))
                self._grids[lens] = grid
        return grid

    def trace(
        self,
        x: float,
        y: float,
        yaw: float,
        lens: LensModel,
        height: float = CAMERA_HEIGHT,
        pitch: float = 0.0,
        spill: GrownSpill | None = None,
    ) -> NDArray[np.int64]:
        """Index of the face each pixel sees, ``(lens.height, lens.width)``.

        :data:`NO_HIT` where the ray escapes, :data:`OUTSIDE_FIELD` outside the lens's field. As :meth:`render`.
        """
        grid = self.rays(lens)
        hits, _, _ = self._cast(grid, x, y, yaw, height, pitch, spill)
        out = np.full(grid.height * grid.width, OUTSIDE_FIELD, dtype=np.int64)
        out[grid.index] = hits
        return out.reshape(grid.height, grid.width)

    def render(
        self,
        x: float,
        y: float,
        yaw: float,
        lens: LensModel,
        height: float = CAMERA_HEIGHT,
        pitch: float = 0.0,
        spill: GrownSpill | None = None,
    ) -> NDArray[np.uint8]:
        """The image, ``(lens.height, lens.width, 3)`` uint8 RGB, of a camera on a robot at ``(x, y, yaw)``.

        Map frame, metres and radians; the camera is ``height`` metres above the floor, looks along the
        robot's heading and is tilted down by ``pitch``. ``spill``: the spill grown (None or scale 1: the scene as
        it is, byte for byte). Deterministic; blocking (tens of milliseconds with Embree): call it from a worker thread.
        """
        grid = self.rays(lens)
        hits, directions, origin = self._cast(grid, x, y, yaw, height, pitch, spill)
        # Start from the lens's blank frame (black outside the field, void inside) and paint the hits.
        image = grid.blank.copy()
        hit = np.flatnonzero(hits >= 0)
        image.reshape(-1, 3)[grid.index[hit]] = self._shade(hits[hit], directions[hit], origin)
        return image

    # -- internals --------------------------------------------------------------------------------

    def _cast(
        self, grid: RayGrid, x: float, y: float, yaw: float, height: float, pitch: float, spill: GrownSpill | None
    ) -> tuple[NDArray[np.int64], NDArray[np.float32], NDArray[np.float64]]:
        """First face hit by every ray of ``grid`` from the pose (or NO_HIT; the floor under ``spill`` as the spill),
        the map-frame rays, the origin."""
        if not all(math.isfinite(v) for v in (x, y, yaw, height, pitch)):
            raise ValueError(f"camera pose must be finite, got x={x} y={y} yaw={yaw} height={height} pitch={pitch}")
        rotation = camera_rotation(yaw, pitch).astype(np.float32)
        directions = grid.directions @ rotation.T
        origin = np.array([x, y, height], dtype=np.float64)
        origins = np.broadcast_to(origin.astype(np.float32), directions.shape)
        if self._cast_lock is None:
            hits = self._intersector.intersects_first(origins, directions)
        else:
            with self._cast_lock:
                hits = self._intersector.intersects_first(origins, directions)
        return self.spill_painter.grow(np.asarray(hits, dtype=np.int64), directions, origin, spill), directions, origin

    def _shade(
        self, faces: NDArray[np.int64], directions: NDArray[np.float32], origin: NDArray[np.float64]
    ) -> NDArray[np.uint8]:
        """sRGB colours of hits on ``faces`` along unit ``directions`` from ``origin`` (module docstring)."""
        table = self._face_table[faces]
        normals = table[:, 0:3]
        n_dot_d = np.einsum("ij,ij->i", normals, directions)
        distance = (table[:, 7] - normals @ origin.astype(np.float32)) / np.where(n_dot_d == 0.0, 1e-12, n_dot_d)
        # Turn each normal towards the camera (two-sided lighting): n.L flips sign with it, |n.d| does not.
        lambert = np.maximum(np.copysign(table[:, 3], -n_dot_d), 0.0)
        gain = AMBIENT + DIFFUSE * lambert + HEADLIGHT * np.abs(n_dot_d)
        gain /= 1.0 + np.square(np.maximum(distance, 0.0) * (1.0 / FALLOFF))
        linear = table[:, 4:7] * gain[:, None]
        codes = (linear * (_LUT_SIZE - 1) + 0.5).astype(np.intp)
        np.clip(codes, 0, _LUT_SIZE - 1, out=codes)
        out: NDArray[np.uint8] = _SRGB_LUT[codes]
        return out


def spill_mask(
    camera: SimCamera,
    x: float,
    y: float,
    yaw: float,
    lens: LensModel,
    spill: GrownSpill,
    height: float = CAMERA_HEIGHT,
    pitch: float = 0.0,
) -> NDArray[np.bool_]:
    """The simulator's truth: True where a pixel of ``camera.render(x, y, yaw, lens, height, pitch, spill)`` sees
    the spill (its mesh, or floor inside its grown outline), ``(lens.height, lens.width)``, from the same rays."""
    return camera.spill_painter.covers(camera.trace(x, y, yaw, lens, height, pitch, spill))


def rgb_to_jpeg(rgb: ArrayLike, quality: int = JPEG_QUALITY) -> bytes:
    """JPEG bytes of an ``(H, W, 3)`` uint8 RGB image (OpenCV, which releases the GIL while encoding).

    Raises ``ValueError`` for another shape or dtype or a quality outside 1..100.
    """
    array = np.asarray(rgb)
    if array.dtype != np.uint8 or array.ndim != 3 or array.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) uint8 RGB image, got {array.dtype} {array.shape}")
    if not 1 <= quality <= 100:
        raise ValueError(f"JPEG quality must be 1..100, got {quality}")
    return encode_jpeg(np.asarray(cv2.cvtColor(array, cv2.COLOR_RGB2BGR), dtype=np.uint8), quality)
