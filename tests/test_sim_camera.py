"""The simulated camera shows what the demo promises: the spill, the panels and the puddle, each from its room.

The scene is the facility twin ``scenes/facility.glb`` when it exists; otherwise a comparable one built here
from ``relay.sim.floorplan.demo_facility()`` (same boxes, same named nodes, glTF Y-up, PBR colours). Expected
colours are read from the GLB with pygltflib, independently of the loader under test.
"""

from __future__ import annotations

import asyncio
import math
import threading
from pathlib import Path

import cv2
import numpy as np
import pygltflib
import pytest
import trimesh
from numpy.typing import NDArray

from relay.config import Lens
from relay.media.lens import LensModel
from relay.sim.camera import (
    DEFAULT_SIZE,
    NO_HIT,
    OUTSIDE_FIELD,
    VOID_RGB,
    SimCamera,
    embree_available,
    rgb_to_jpeg,
)
from relay.sim.floorplan import demo_facility
from relay.twin.frames import ROS_TO_GLTF, map_to_scene_matrix

ROOT = Path(__file__).resolve().parents[1]
FACILITY_GLB = ROOT / "scenes" / "facility.glb"

SPILL = (1.8, 8.2)
PUDDLE = (15.6, 7.6)

# -- a comparable scene, for when scenes/facility.glb is not there ----------------------------------------

# Linear base colours, like the twin's: a yellow-green chemical, water, warning yellow on grey panels.
SPILL_RGB = (0.3, 0.9, 0.0)
PUDDLE_RGB = (0.03, 0.25, 0.85)
WARNING_RGB = (1.0, 0.5, 0.0)


def _add(
    scene: trimesh.Scene, name: str, mesh: trimesh.Trimesh, rgb: tuple[float, float, float], parent: str | None = None
) -> None:
    """Add ``mesh`` (built in ROS coordinates) as node ``name``, converted to glTF Y-up, with a PBR colour."""
    mesh = mesh.copy()
    mesh.apply_transform(ROS_TO_GLTF)
    material = trimesh.visual.material.PBRMaterial(  # type: ignore[no-untyped-call]
        name=f"{name}_material", baseColorFactor=[*rgb, 1.0]
    )
    mesh.visual = trimesh.visual.TextureVisuals(material=material)  # type: ignore[no-untyped-call]
    scene.add_geometry(mesh, node_name=name, geom_name=name, parent_node_name=parent)


def _box(x0: float, y0: float, z0: float, x1: float, y1: float, z1: float) -> trimesh.Trimesh:
    box: trimesh.Trimesh = trimesh.creation.box(extents=(x1 - x0, y1 - y0, z1 - z0))
    box.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2))
    return box


def _disc(x: float, y: float, radius: float) -> trimesh.Trimesh:
    disc: trimesh.Trimesh = trimesh.creation.cylinder(radius=radius, height=0.01, sections=48)
    disc.apply_translation((x, y, 0.005))
    return disc


def build_facility_glb(path: Path) -> Path:
    """Write a GLB of the demo facility's boxes with the twin's named nodes (floor, walls, barrels,
    panel_1..3 with warning fronts as child nodes, pipe_support, spill, puddle) and return ``path``."""
    plan = demo_facility()
    scene = trimesh.Scene()
    _add(scene, "floor", _box(0.0, 0.0, -0.05, plan.width, plan.depth, 0.0), (0.35, 0.35, 0.36))
    for wall in plan.walls:
        _add(
            scene, wall.name, _box(wall.min_x, wall.min_y, 0.0, wall.max_x, wall.max_y, wall.height), (0.78, 0.7, 0.56)
        )
    for box in plan.obstacles:
        body = _box(box.min_x, box.min_y, 0.0, box.max_x, box.max_y, box.height)
        if box.kind == "barrel":
            body = trimesh.creation.cylinder(radius=0.5 * (box.max_x - box.min_x), height=box.height, sections=32)
            body.apply_translation((*box.centre, box.height / 2))
            _add(scene, box.name, body, (0.3, 0.34, 0.38))
        elif box.kind == "panel":
            # Fronts face south, into the room: a warning-yellow door with a black label.
            _add(scene, box.name, body, (0.5, 0.52, 0.55))
            front = _box(box.min_x + 0.05, box.min_y - 0.02, 0.3, box.max_x - 0.05, box.min_y, 1.9)
            _add(scene, f"{box.name}_front", front, WARNING_RGB, parent=box.name)
            label = _box(box.min_x + 0.3, box.min_y - 0.03, 1.3, box.max_x - 0.3, box.min_y - 0.02, 1.6)
            _add(scene, f"{box.name}_label", label, (0.02, 0.02, 0.02), parent=box.name)
        else:
            _add(scene, box.name, body, (0.25, 0.25, 0.27))
    _add(scene, "spill", _disc(*SPILL, 0.7), SPILL_RGB)
    _add(scene, "puddle", _disc(*PUDDLE, 0.8), PUDDLE_RGB)
    path.write_bytes(scene.export(file_type="glb"))  # type: ignore[no-untyped-call]
    return path


# -- colours as a person sees them --------------------------------------------------------------------------


def base_colour(glb: Path, node_name: str) -> tuple[float, float, float]:
    """The most saturated linear base colour among the primitives of node ``node_name`` and its children."""
    gltf = pygltflib.GLTF2().load(str(glb))
    by_name = {node.name: node for node in gltf.nodes}
    pending, colours = [by_name[node_name]], []
    while pending:
        node = pending.pop()
        pending.extend(gltf.nodes[i] for i in node.children or [])
        if node.mesh is not None:
            for primitive in gltf.meshes[node.mesh].primitives:
                factor = gltf.materials[primitive.material].pbrMetallicRoughness.baseColorFactor
                colours.append(tuple(float(c) for c in factor[:3]))
    assert colours, f"node {node_name} has no coloured primitive"
    return max(colours, key=lambda c: (max(c) - min(c)) / max(max(c), 1e-6))  # type: ignore[return-value]


def hue_saturation(rgb: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Hue (degrees) and saturation (0..1) of RGB values in [0, 1], shape (..., 3)."""
    high, low = rgb.max(axis=-1), rgb.min(axis=-1)
    chroma = high - low
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    safe = np.where(chroma > 0, chroma, 1.0)
    hue = np.select(
        [high == r, high == g],
        [((g - b) / safe) % 6.0, (b - r) / safe + 2.0],
        (r - g) / safe + 4.0,
    )
    return hue * 60.0, np.where(high > 0, chroma / np.where(high > 0, high, 1.0), 0.0)


def matches_colour(image: NDArray[np.uint8], linear: tuple[float, float, float]) -> NDArray[np.bool_]:
    """Pixels a person would call this base colour: its hue (as the browser shows it, in sRGB) within 12
    degrees, clearly saturated, not dark. Shading changes brightness, not hue."""
    base = np.asarray(linear)
    srgb = np.where(base <= 0.0031308, 12.92 * base, 1.055 * base ** (1 / 2.4) - 0.055)
    want_hue, want_sat = hue_saturation(srgb)
    hue, sat = hue_saturation(image.astype(np.float64) / 255.0)
    delta = np.abs((hue - want_hue + 180.0) % 360.0 - 180.0)
    matched: NDArray[np.bool_] = (delta <= 12.0) & (sat >= 0.6 * want_sat) & (image.max(axis=-1) >= 60)
    return matched


# -- fixtures -----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def glb(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if FACILITY_GLB.exists():
        return FACILITY_GLB
    return build_facility_glb(tmp_path_factory.mktemp("scene") / "facility.glb")


@pytest.fixture(scope="module")
def camera(glb: Path) -> SimCamera:
    if not embree_available():
        # pyproject.toml installs embreex on x86_64; elsewhere only the slow fallback exists, which cannot
        # render 480x480 views in a test's time (it is checked at 40x40 below).
        pytest.skip("embreex does not import on this machine: full-size views need the Embree ray engine")
    return SimCamera.load(glb)


@pytest.fixture(scope="module")
def lens() -> LensModel:
    return LensModel.create("equidistant", DEFAULT_SIZE, DEFAULT_SIZE, 180.0)


def facing(x: float, y: float, target: tuple[float, float]) -> tuple[float, float, float]:
    return x, y, math.atan2(target[1] - y, target[0] - x)


def centre_window(image: NDArray[np.uint8], fraction: float = 0.3) -> NDArray[np.uint8]:
    h, w = image.shape[:2]
    dh, dw = int(h * fraction / 2), int(w * fraction / 2)
    return image[h // 2 - dh : h // 2 + dh, w // 2 - dw : w // 2 + dw]


# -- what the operator sees ---------------------------------------------------------------------------------


def test_robot1_facing_the_spill_sees_it_in_the_middle(camera: SimCamera, lens: LensModel, glb: Path) -> None:
    image = camera.render(*facing(3.0, 6.5, SPILL), lens)
    spill = matches_colour(image, base_colour(glb, "spill"))
    assert matches_colour(centre_window(image), base_colour(glb, "spill")).sum() > 400
    # Those pixels really are the spill, not something else of a similar colour.
    faces = camera.trace(*facing(3.0, 6.5, SPILL), lens)
    assert camera.faces_under("spill")[faces[spill]].mean() > 0.95


def test_robot1_facing_a_plain_wall_sees_no_spill(camera: SimCamera, lens: LensModel, glb: Path) -> None:
    image = camera.render(3.0, 6.0, 0.0, lens)  # east, towards the x = 6 divider
    assert matches_colour(image, base_colour(glb, "spill")).sum() == 0
    # Not a blank frame either: the wall fills the middle of the view.
    faces = camera.trace(3.0, 6.0, 0.0, lens)
    middle = faces[DEFAULT_SIZE // 2 - 20 : DEFAULT_SIZE // 2 - 5, DEFAULT_SIZE // 2 - 20 : DEFAULT_SIZE // 2 + 20]
    assert (middle >= 0).all()


def test_panels_face_robot2_in_power_distribution(camera: SimCamera, lens: LensModel, glb: Path) -> None:
    warning = base_colour(glb, "panel_1")
    north = matches_colour(camera.render(9.0, 6.5, math.pi / 2, lens), warning)
    assert north.sum() > 2000
    # Three panels side by side, centred ahead: warning colour on both sides of the middle column.
    columns = np.flatnonzero(north.any(axis=0))
    assert columns.min() < DEFAULT_SIZE / 2 - 40 < DEFAULT_SIZE / 2 + 40 < columns.max()
    south = matches_colour(camera.render(9.0, 6.5, -math.pi / 2, lens), warning)
    assert south.sum() == 0


def test_puddle_is_seen_from_plumbing(camera: SimCamera, lens: LensModel, glb: Path) -> None:
    image = camera.render(*facing(15.0, 5.5, PUDDLE), lens)
    assert matches_colour(centre_window(image), base_colour(glb, "puddle")).sum() > 300


def test_turning_left_moves_the_scene_right(camera: SimCamera, lens: LensModel, glb: Path) -> None:
    """Counter-clockwise yaw (REP 103) must shift what is ahead towards the right of the image, not mirror it."""
    warning = base_colour(glb, "panel_1")
    ahead = np.flatnonzero(matches_colour(camera.render(9.0, 6.5, math.pi / 2, lens), warning).any(axis=0)).mean()
    left = np.flatnonzero(matches_colour(camera.render(9.0, 6.5, math.pi / 2 + 0.4, lens), warning).any(axis=0)).mean()
    assert left > ahead + 30


def test_pitching_down_shows_more_floor(camera: SimCamera, lens: LensModel) -> None:
    floor = camera.faces_under("floor")

    def floor_fraction(pitch: float) -> float:
        faces = camera.trace(9.0, 5.0, math.pi / 2, lens, pitch=pitch)
        return float(floor[faces[faces >= 0]].sum() / faces.size)

    level, down, up = floor_fraction(0.0), floor_fraction(0.4), floor_fraction(-0.4)
    assert up < level - 0.05 and down > level + 0.05


def test_higher_camera_looks_down_on_the_spill(camera: SimCamera, lens: LensModel, glb: Path) -> None:
    low = matches_colour(camera.render(*facing(3.0, 6.5, SPILL), lens), base_colour(glb, "spill")).sum()
    high = matches_colour(camera.render(*facing(3.0, 6.5, SPILL), lens, height=1.5), base_colour(glb, "spill")).sum()
    assert high > 2 * low


def test_equidistant_180_is_black_outside_the_image_circle(camera: SimCamera) -> None:
    wide = LensModel.create("equidistant", 320, 240, 180.0)
    image = camera.render(9.0, 5.0, 1.0, wide)
    v, u = np.mgrid[0:240, 0:320]
    outside = np.hypot(u - 159.5, v - 119.5) > 120.0
    assert (image[outside] == 0).all()
    inside_lit = image[~outside].max(axis=-1) > 0
    assert inside_lit.mean() > 0.99
    faces = camera.trace(9.0, 5.0, 1.0, wide)
    assert (faces[outside] == OUTSIDE_FIELD).all() and (faces[~outside] != OUTSIDE_FIELD).all()


def test_rays_into_the_open_sky_are_void_not_black(camera: SimCamera) -> None:
    # Straight up from the middle of a room there is no ceiling in the twin.
    up = LensModel.create("pinhole", 64, 64, 40.0)
    faces = camera.trace(9.0, 6.5, 0.0, up, pitch=-math.pi / 2)
    image = camera.render(9.0, 6.5, 0.0, up, pitch=-math.pi / 2)
    assert (faces == NO_HIT).all()
    assert (image == np.array(VOID_RGB, dtype=np.uint8)).all()


@pytest.mark.parametrize(
    "lens_model",
    [
        LensModel.create("equisolid", 240, 240, 190.0),
        LensModel.create("stereographic", 240, 240, 200.0),
        LensModel.create("pinhole", 320, 240, 90.0),
        LensModel.create(
            "opencv_fisheye",
            320,
            240,
            180.0,
            (110.0, 0.0, 159.5, 0.0, 110.0, 119.5, 0.0, 0.0, 1.0),
            (0.02, -0.01, 0.0, 0.0),
        ),
    ],
    ids=lambda lens: lens.model,
)
def test_every_lens_model_puts_the_spill_ahead(camera: SimCamera, lens_model: LensModel, glb: Path) -> None:
    image = camera.render(*facing(3.0, 6.5, SPILL), lens_model)
    assert matches_colour(centre_window(image, 0.4), base_colour(glb, "spill")).sum() > 30


def test_render_is_deterministic_and_thread_safe(camera: SimCamera) -> None:
    lens = LensModel.create("equidistant", 256, 256, 180.0)  # smaller: many renders, same code paths
    poses = [(3.0, 6.5, 2.2), (9.0, 6.5, 1.57), (15.0, 5.5, 1.2), (9.0, 1.5, 0.0)]
    expected = [camera.render(*pose, lens) for pose in poses]
    assert np.array_equal(camera.render(*poses[0], lens), expected[0])
    results: dict[int, NDArray[np.uint8]] = {}

    def worker(index: int) -> None:
        results[index] = camera.render(*poses[index % len(poses)], lens)

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for index, image in results.items():
        assert np.array_equal(image, expected[index % len(poses)]), f"render {index} differs when run concurrently"


async def test_rendering_in_a_worker_thread_keeps_the_event_loop_running(camera: SimCamera) -> None:
    """How the backend uses it: frames render in asyncio.to_thread while the loop keeps serving poses and acks."""
    lens = LensModel.create("equidistant", 320, 320, 180.0)
    rendering = threading.Event()
    ticks_while_rendering = 0
    done = asyncio.Event()

    async def ticker() -> None:
        nonlocal ticks_while_rendering
        while not done.is_set():
            await asyncio.sleep(0.002)
            ticks_while_rendering += rendering.is_set()

    def render(yaw: float) -> NDArray[np.uint8]:
        rendering.set()
        try:
            return camera.render(3.0, 6.5, yaw, lens)
        finally:
            rendering.clear()

    task = asyncio.create_task(ticker())
    frames = [await asyncio.to_thread(render, 2.0 + 0.05 * i) for i in range(4)]
    done.set()
    await task
    for i, frame in enumerate(frames):
        # (Compared off the loop too: this test's own blocking call would trip conftest's loop watchdog.)
        assert np.array_equal(frame, await asyncio.to_thread(camera.render, 3.0, 6.5, 2.0 + 0.05 * i, lens))
    # The loop ran during the renders, not only between them.
    assert ticks_while_rendering >= len(frames), f"the loop ticked {ticks_while_rendering} times while rendering"


def test_jpeg_starts_with_soi_and_decodes_to_the_image(camera: SimCamera, lens: LensModel) -> None:
    image = camera.render(*facing(3.0, 6.5, SPILL), lens)
    data = rgb_to_jpeg(image, quality=80)
    assert data[:2] == b"\xff\xd8"
    assert len(data) < image.nbytes / 10  # a small fraction of raw RGB, as the camera path budget says
    decoded = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    assert decoded is not None, "OpenCV could not decode the JPEG"
    assert decoded.shape == (DEFAULT_SIZE, DEFAULT_SIZE, 3)
    # Same picture, same channel order (OpenCV decodes to BGR).
    assert np.abs(decoded[..., ::-1].astype(int) - image.astype(int)).mean() < 4.0
    assert len(rgb_to_jpeg(image, quality=30)) < len(data)


@pytest.mark.parametrize(
    "bad", [np.zeros((4, 4), np.uint8), np.zeros((4, 4, 4), np.uint8), np.zeros((4, 4, 3), np.float32)]
)
def test_jpeg_refuses_what_is_not_an_rgb_image(bad: NDArray[np.generic]) -> None:
    with pytest.raises(ValueError, match="uint8 RGB"):
        rgb_to_jpeg(bad)


def test_fit_lens_scales_configured_cameras_into_the_budget(camera: SimCamera) -> None:
    k = (774.65, 0.0, 987.61, 0.0, 776.84, 592.27, 0.0, 0.0, 1.0)
    fitted = camera.fit_lens(Lens("opencv_fisheye", 140.0, k, (-0.0195, -0.003, -0.0006, 0.0001)), 1920, 1080)
    assert max(fitted.width, fitted.height) == camera.max_size
    assert fitted.width / fitted.height == pytest.approx(1920 / 1080, rel=0.01)
    assert fitted.fx == pytest.approx(774.65 * fitted.width / 1920)
    small = camera.fit_lens(Lens("equidistant", 180.0), 200, 200)
    assert (small.width, small.height) == (200, 200)


# -- loading the twin ---------------------------------------------------------------------------------------


def test_loader_converts_gltf_to_ros_and_keeps_colours_and_hierarchy(tmp_path: Path) -> None:
    camera = SimCamera.load(build_facility_glb(tmp_path / "built.glb"))
    spill = camera.faces_under("spill")
    centre = camera.mesh.triangles_center[spill].mean(axis=0)
    assert centre[:2] == pytest.approx(SPILL, abs=0.05)
    assert 0.0 <= centre[2] < 0.02, "the spill lies on the floor (z up after the glTF conversion)"
    np.testing.assert_allclose(camera.albedo[spill], np.tile(SPILL_RGB, (spill.sum(), 1)), atol=1 / 255)
    # Child nodes (the panel fronts) belong to their panel.
    front = camera.faces_under("panel_2_front")
    assert front.any() and not (front & ~camera.faces_under("panel_2")).any()
    np.testing.assert_allclose(camera.albedo[front][0], WARNING_RGB, atol=1 / 255)
    # The wall behind the panels is at y = 10 - 0.2 .. 10, the floor at z <= 0.
    lo, hi = camera.mesh.bounds
    assert lo == pytest.approx((0.0, 0.0, -0.05), abs=1e-6) and hi == pytest.approx((18.0, 10.0, 2.5), abs=1e-6)


def test_map_to_scene_lets_render_take_map_poses(glb: Path, camera: SimCamera, lens: LensModel) -> None:
    # The map frame sits at (2, -1) in the scene, turned by 90 degrees: a map pose (px, py, yaw) is the
    # scene pose Rz(90)(px, py) + (2, -1) with yaw + 90 degrees.
    shifted = SimCamera.load(glb, map_to_scene=map_to_scene_matrix(2.0, -1.0, 0.0, math.pi / 2))
    scene_x, scene_y, scene_yaw = facing(3.0, 6.5, SPILL)
    map_x, map_y = scene_y + 1.0, -(scene_x - 2.0)
    moved = shifted.render(map_x, map_y, scene_yaw - math.pi / 2, lens).astype(int)
    same = camera.render(scene_x, scene_y, scene_yaw, lens).astype(int)
    # Rounding in the transformed vertices may flip a ray grazing an edge; the picture is the same.
    assert (np.abs(moved - same).max(axis=-1) <= 1).mean() > 0.999


def test_face_colours_are_used_when_there_is_no_material() -> None:
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    box.visual = trimesh.visual.ColorVisuals(box, face_colors=[200, 100, 50, 255])
    camera = SimCamera.from_scene(trimesh.Scene(box), y_up=False)
    np.testing.assert_allclose(camera.albedo, np.tile([200 / 255, 100 / 255, 50 / 255], (12, 1)), atol=1e-6)


def test_triangle_fallback_sees_what_embree_sees(glb: Path) -> None:
    small = LensModel.create("equidistant", 40, 40, 180.0)
    pose = facing(3.0, 6.5, SPILL)
    fallback = SimCamera.load(glb, engine="triangle")
    assert fallback.engine == "triangle" and fallback.max_size < DEFAULT_SIZE
    faces = fallback.trace(*pose, small)
    assert fallback.faces_under("spill")[faces[17:25, 14:26][faces[17:25, 14:26] >= 0]].sum() >= 4
    if not embree_available():
        return
    embree = SimCamera.load(glb, engine="embree")
    assert embree.engine == "embree"
    # Faces may differ where a ray grazes a shared edge; the pictures must not.
    assert (embree.trace(*pose, small) == faces).mean() > 0.97
    assert np.abs(embree.render(*pose, small).astype(int) - fallback.render(*pose, small).astype(int)).mean() < 3.0


def test_bad_poses_are_refused(camera: SimCamera, lens: LensModel) -> None:
    with pytest.raises(ValueError, match="finite"):
        camera.render(float("nan"), 1.0, 0.0, lens)
