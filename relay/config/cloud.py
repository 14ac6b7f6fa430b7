"""robots.yaml's ``cloud``: the live 3D map's voxel size, memory budget, saving and the simulated depth cameras."""

from __future__ import annotations

from yaml.nodes import Node

from .model import Cloud
from .reader import _Reader

#: Below a centimetre a site's map outgrows any budget (a 20 x 10 x 3 m facility's walls alone: millions of voxels);
#: above a metre it shows no wall a person would recognise.
VOXEL_RANGE = (0.01, 1.0)
#: The simulated depth cameras' rate ceiling: each sweep of the demo's 3 robots costs ~15 ms of a worker's time.
MAX_SIM_DEPTH_RATE = 10.0


def cloud(reader: _Reader, node: Node) -> Cloud:
    path = "cloud"
    if reader.value(node) is None:  # `cloud:` alone: the defaults
        return Cloud()
    f = reader.mapping(node, path, ("voxel", "budget_blocks", "save_every", "sim_depth_rate"))
    voxel = reader.get(f, "voxel", path, lambda n, p: reader.number(n, p, positive=True), Cloud.voxel)
    low, high = VOXEL_RANGE
    if not low <= voxel <= high:
        raise reader.fail(f["voxel"], "cloud.voxel", f"expected a voxel side of {low:g} to {high:g} m, got {voxel:g}")
    rate = reader.get(
        f, "sim_depth_rate", path, lambda n, p: reader.number(n, p, non_negative=True), Cloud.sim_depth_rate
    )
    if rate > MAX_SIM_DEPTH_RATE:
        raise reader.fail(
            f["sim_depth_rate"], "cloud.sim_depth_rate", f"expected at most {MAX_SIM_DEPTH_RATE:g} Hz, got {rate:g}"
        )
    return Cloud(
        voxel=voxel,
        budget_blocks=reader.get(f, "budget_blocks", path, reader.integer, Cloud.budget_blocks),
        save_every=reader.get(f, "save_every", path, lambda n, p: reader.number(n, p, positive=True), Cloud.save_every),
        sim_depth_rate=rate,
    )
