"""The session recorder (issue #34): what the relay sent and was sent goes into an MCAP file that the `mcap`
library reads back, byte for byte and in order; the loop never waits for it (a full queue drops, counted); a file
that exists is never overwritten and a place it cannot write is named."""

from __future__ import annotations

import json
import re
from pathlib import Path

import orjson
import pytest
from mcap.reader import make_reader

from relay.errors import RecordingError
from relay.replay.recorder import SessionRecorder


def test_a_session_reads_back_from_its_mcap_in_order(tmp_path: Path) -> None:
    path = tmp_path / "session.mcap"
    recorder = SessionRecorder(path)
    recorder.open()
    sent = []
    for k in range(500):
        pose = orjson.dumps({"identifier": "robot1/pose", "x": k * 0.01, "y": 2.0, "yaw": 0.0, "stamp": k / 30})
        recorder.record("/out/robot1/pose", pose, 1_000_000_000 + k * 33_333_333)
        sent.append(("/out/robot1/pose", pose))
        if k % 100 == 0:
            goal = orjson.dumps({"identifier": "robot2/goal_pose", "x": 3.0, "y": 4.0, "id": k})
            recorder.record("/in/c1-abc123", goal, 1_000_000_000 + k * 33_333_333 + 1)
            sent.append(("/in/c1-abc123", goal))
    recorder.close()
    with path.open("rb") as f:
        reader = make_reader(f)
        read = [(channel.topic, message.data) for _, channel, message in reader.iter_messages(log_time_order=True)]
        summary = reader.get_summary()
    assert read == sent
    assert summary is not None and summary.statistics is not None and summary.statistics.message_count == 505
    assert {c.message_encoding for c in summary.channels.values()} == {"json"}
    assert json.loads(read[-1][1])["x"] == pytest.approx(4.99)
    assert recorder.written == 505 and recorder.dropped == 0


def test_what_waits_for_the_writer_is_bounded_and_a_full_list_drops_counted(tmp_path: Path) -> None:
    recorder = SessionRecorder(tmp_path / "never-opened.mcap", max_queue=10)
    for k in range(15):  # no writer drains it: the loop must still never wait
        recorder.record("/out/robot1/pose", b"{}", k)
    assert len(recorder.pending) == 10 and recorder.dropped == 5


def test_an_existing_file_is_kept_and_an_unwritable_place_named(tmp_path: Path) -> None:
    existing = tmp_path / "session.mcap"
    existing.write_bytes(b"yesterday's session")
    with pytest.raises(RecordingError, match=re.escape(f"cannot record the session to {existing}: File exists")):
        SessionRecorder(existing).open()
    assert existing.read_bytes() == b"yesterday's session"
    blocked = tmp_path / "a-file"
    blocked.write_text("")
    with pytest.raises(RecordingError, match=r"cannot record the session to .*a-file/session\.mcap"):
        SessionRecorder(blocked / "session.mcap").open()
