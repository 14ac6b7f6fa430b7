"""The suite gives back the shared memory its killed ROS processes leave (tests/helpers/shared_memory.py): a Fast
DDS segment whose lock nobody holds is removed, one a living process holds stays."""

from __future__ import annotations

import fcntl
from pathlib import Path

from tests.helpers.shared_memory import remove_orphaned_segments


def test_a_dead_processs_segment_is_removed_and_a_living_ones_stays(tmp_path: Path) -> None:
    dead, alive = "fastdds_00112233aabbccdd", "fastdds_99887766ffeeddcc"
    for name in (dead, alive):
        (tmp_path / name).write_bytes(b"\0" * 65536)
        (tmp_path / f"{name}_el").write_bytes(b"")
    (tmp_path / "fastdds_port7411").write_bytes(b"port")  # not a segment: left alone
    with open(tmp_path / f"{alive}_el", "ab") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        freed = remove_orphaned_segments(tmp_path)
        assert freed >= 65536
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted([alive, f"{alive}_el", "fastdds_port7411"])
    assert remove_orphaned_segments(tmp_path / "absent") == 0
