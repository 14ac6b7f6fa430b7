"""Benchmark of the simulated camera: snapshot latency and live-stream rate per image size and ray engine.

    .venv/bin/python bench/bench_sim_camera.py [--frames 20] [--sizes 320 480 640] [--fallback-sizes 48 64]

Budget (docs: DESIGN.md, camera path): a snapshot (render + JPEG) under 200 ms, a live stream of one robot at
5 fps or more, on a 2-core machine. A robot drives through chemical storage towards the spill, so every frame
has a new pose as in a live stream. Reports, per configuration, the median and 95th percentile wall time of
render and of JPEG encoding, the CPU time of the rendering thread, the stream rate one worker thread
sustains, and the rate of two renders in parallel (how much Embree and numpy release the GIL). Wall times
depend on what else the machine runs; CPU times much less.

Uses scenes/facility.glb, or the comparable scene of tests/test_sim_camera.py when it does not exist yet.
"""

from __future__ import annotations

import argparse
import logging
import math
import statistics
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run as a script from anywhere in a checkout

from relay.media.lens import LensModel  # noqa: E402
from relay.sim.camera import SimCamera, embree_available, rgb_to_jpeg  # noqa: E402

logger = logging.getLogger("bench_sim_camera")

SNAPSHOT_BUDGET = 0.200  # s
STREAM_TARGET = 5.0  # frames per second


@dataclass(frozen=True)
class Result:
    engine: str
    size: int
    render_median: float
    render_p95: float
    render_cpu: float
    jpeg_median: float
    jpeg_bytes: int
    parallel_fps: float

    @property
    def snapshot(self) -> float:
        return self.render_median + self.jpeg_median

    @property
    def stream_fps(self) -> float:
        return 1.0 / self.snapshot


def poses(count: int) -> list[tuple[float, float, float]]:
    """A drive from the chemical storage door towards the spill, turning as it goes."""
    out = []
    for i in range(count):
        s = i / max(count - 1, 1)
        x, y = 3.0 - 0.8 * s, 4.0 + 3.0 * s
        out.append((x, y, math.atan2(8.2 - y, 1.8 - x) + 0.3 * math.sin(6.0 * s)))
    return out


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def measure(camera: SimCamera, size: int, frames: int) -> Result:
    lens = LensModel.create("equidistant", size, size, 180.0)
    camera.render(3.0, 5.0, 1.0, lens)  # warm-up: the lens's rays are computed once
    render_wall: list[float] = []
    render_cpu: list[float] = []
    jpeg_wall: list[float] = []
    jpeg_bytes = 0
    for pose in poses(frames):
        t0, c0 = time.perf_counter(), time.thread_time()
        image = camera.render(*pose, lens)
        t1, c1 = time.perf_counter(), time.thread_time()
        data = rgb_to_jpeg(image, quality=80)
        t2 = time.perf_counter()
        render_wall.append(t1 - t0)
        render_cpu.append(c1 - c0)
        jpeg_wall.append(t2 - t1)
        jpeg_bytes = len(data)

    # Two robots' frames at once, each in its own thread, as two asyncio.to_thread calls would run them.
    half = poses(frames)[: max(2, frames // 2)]

    def stream() -> None:
        for pose in half:
            rgb_to_jpeg(camera.render(*pose, lens))

    threads = [threading.Thread(target=stream) for _ in range(2)]
    start = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    parallel_fps = 2 * len(half) / (time.perf_counter() - start)
    return Result(
        camera.engine,
        size,
        statistics.median(render_wall),
        percentile(render_wall, 0.95),
        statistics.median(render_cpu),
        statistics.median(jpeg_wall),
        jpeg_bytes,
        parallel_fps,
    )


def report(result: Result) -> None:
    verdict = (
        "meets the budget"
        if result.snapshot < SNAPSHOT_BUDGET and result.stream_fps >= STREAM_TARGET
        else "MISSES the budget"
    )
    logger.info(
        "%-8s %4dx%-4d render %6.1f ms (p95 %6.1f, cpu %6.1f)  jpeg %5.1f ms %6.1f kB  snapshot %6.1f ms  "
        "stream %5.1f fps  2 threads %5.1f fps  -> %s",
        result.engine,
        result.size,
        result.size,
        1000 * result.render_median,
        1000 * result.render_p95,
        1000 * result.render_cpu,
        1000 * result.jpeg_median,
        result.jpeg_bytes / 1000,
        1000 * result.snapshot,
        result.stream_fps,
        result.parallel_fps,
        verdict,
    )


def scene_path(workdir: Path) -> Path:
    glb = ROOT / "scenes" / "facility.glb"
    if glb.exists():
        return glb
    from tests.test_sim_camera import build_facility_glb

    logger.info("scenes/facility.glb does not exist yet: using the test scene built from the floor plan")
    return build_facility_glb(workdir / "facility.glb")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=20, help="frames per configuration (default 20)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[320, 480, 640], help="square sizes with Embree")
    parser.add_argument(
        "--fallback-sizes", type=int, nargs="*", default=[48, 64], help="square sizes with the triangle engine"
    )
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    with tempfile.TemporaryDirectory() as workdir:
        glb = scene_path(Path(workdir))
        logger.info(
            "scene %s; budget: snapshot < %.0f ms, stream >= %.0f fps", glb, 1000 * SNAPSHOT_BUDGET, STREAM_TARGET
        )
        if embree_available():
            embree = SimCamera.load(glb, engine="embree")
            for size in args.sizes:
                report(measure(embree, size, args.frames))
        else:
            logger.warning("embreex does not import here: only the fallback engine is measured")
        if args.fallback_sizes:
            fallback = SimCamera.load(glb, engine="triangle")
            for size in args.fallback_sizes:
                report(measure(fallback, size, max(2, min(args.frames, 6))))


if __name__ == "__main__":
    main()
