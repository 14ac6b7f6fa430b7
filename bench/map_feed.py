"""A robot's lidar for the benchmarks' synthetic fleet (bench/relay_proc.py ``--map-feed HZ``): the shared real Velodyne
scan (../shared/data/pointcloud/fast_gicp_velodyne_pair, 69 000 points) as a robot's cloud, ``rate`` times a second,
the robot driving on and turning a little each time, so that the relay's live 3D map keeps fusing and streaming
changed blocks to every client, as a fleet exploring does (bench/bench_map_beside.py)."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

import numpy as np

from relay.cloud.pcd import read_pcd
from relay.fleet.events import CloudEvent

from .bench_cloud_fusion import DATA

#: The robot drives on this far a cloud (m), and turns this much (rad): every cloud sees some new space.
STEP_M = 0.05
TURN_RAD = 0.02


class MapFeed(threading.Thread):
    """Clouds of ``robot`` at ``rate`` Hz, handed to ``post`` (the backend's crossing to the loop) until stopped."""

    def __init__(self, robot: str, rate: float, post: Callable[[CloudEvent], None]) -> None:
        super().__init__(name="map-feed", daemon=True)
        self.robot, self.rate, self.post = robot, rate, post
        self.points = read_pcd(DATA / "251370668.pcd").cloud().xyz
        self.sent = 0
        self._stop_event = threading.Event()

    def stop(self) -> None:
        self._stop_event.set()

    def run(self) -> None:
        period = 1.0 / self.rate
        while not self._stop_event.wait(period):
            k = self.sent
            c, s = math.cos(TURN_RAD * k), math.sin(TURN_RAD * k)
            pose = np.eye(4)
            pose[:2, :2] = [[c, -s], [s, c]]
            pose[:3, 3] = (STEP_M * k, 0.0, 1.0)  # the lidar a metre up
            self.post(CloudEvent(self.robot, time.time(), self.points, pose))
            self.sent += 1
