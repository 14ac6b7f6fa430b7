"""A station session into one MCAP file: what the relay sent (robots' poses, readings and statuses, estops, answers)
and what it was sent (every command, with the client that sent it), each message as the JSON bytes that went over
the wire, on a channel per identifier (``/out/robot1/pose``, ``/in/c3-ab12cd``), stamped with the relay's wall clock.

The event loop never waits for the file: :meth:`SessionRecorder.record` appends the bytes to a bounded list and a
thread of the recorder's own writes what has gathered every WRITE_EVERY_S (MCAP's chunks, zstd-compressed); when
the list is full the message is dropped and counted (``dropped``, said in the log line when the recording closes),
so a disk that stalls costs the recording, never a stop. Gathered, not queued one by one: a queue's put woke the
writer for every message, and the two threads took the interpreter from each other 3 000 times a second at 100
robots' poses (the recording cost the relay 35 % more CPU, bench/bench_recording.py). JSON messages go in as JSON
(MCAP's ``json`` encoding, with a permissive JSON Schema), which Foxglove and the ``mcap`` library read as they are.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from pathlib import Path
from typing import IO, Final

from mcap.writer import Writer

from ..errors import RecordingError

logger = logging.getLogger(__name__)

#: Messages waiting for the writer at most: 100 robots' poses at 30 Hz for 3 s.
MAX_QUEUE: Final = 10_000
#: How often the writer takes what has gathered (s): a few hundred messages at a time at 100 robots.
WRITE_EVERY_S: Final = 0.1
#: The writer lets the event loop's thread run after this many messages: left to the interpreter's switch interval
#: (5 ms), a burst of 300 held the loop up to 7 ms.
YIELD_EVERY: Final = 16
#: The schema every channel shares: a JSON object (the protocol's own schema is docs/protocol.md's).
_SCHEMA: Final = b'{"type": "object"}'
#: Topics per recording at most: identifiers are bounded by the fleet, clients' ids by the connections made.
MAX_CHANNELS: Final = 10_000


class SessionRecorder:
    def __init__(self, path: Path, *, max_queue: int = MAX_QUEUE) -> None:
        self.path = Path(path)
        self.max_queue = max_queue
        #: (topic, bytes, stamp) waiting for the writer: the loop appends, the writer pops (a deque does both safely).
        self.pending: collections.deque[tuple[str, bytes, int]] = collections.deque()
        self.dropped = 0  # by the loop: the list was full (only the loop adds to it)
        self.lost = 0  # by the writer: past MAX_CHANNELS, or after the file failed (only the writer adds to it)
        self.written = 0
        self._channels: dict[str, int] = {}
        self._closing = threading.Event()
        self._failed = False
        self._thread: threading.Thread | None = None
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None

    def open(self) -> None:
        """Create the file and start the writer (blocking: call it off the event loop). Refuses to overwrite."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("xb")
        except OSError as exc:
            raise RecordingError(f"cannot record the session to {self.path}: {exc.strerror or exc}") from None
        self._writer = Writer(self._file)
        self._writer.start(profile="", library="xr-relay")
        self._schema = self._writer.register_schema("xr_relay.Message", "jsonschema", _SCHEMA)
        self._thread = threading.Thread(target=self._run, name="session-recorder", daemon=True)
        self._thread.start()

    def record(self, topic: str, data: bytes, log_time_ns: int | None = None) -> None:
        """Keep one message for the file; never blocks (a full list drops it, counted)."""
        if len(self.pending) >= self.max_queue:
            self.dropped += 1
            return
        self.pending.append((topic, data, time.time_ns() if log_time_ns is None else log_time_ns))

    def _run(self) -> None:
        while True:
            closing = self._closing.wait(WRITE_EVERY_S)  # set by close: what is left is written, then the thread ends
            written = 0
            while self.pending:
                self._write(*self.pending.popleft())
                written += 1
                if written % YIELD_EVERY == 0:
                    time.sleep(0)  # the interpreter to the loop's thread: a burst held it up to 7 ms (a pose's p99)
            if closing:
                return

    def _write(self, topic: str, data: bytes, stamp: int) -> None:
        assert self._writer is not None
        if self._failed:
            self.lost += 1
            return
        try:
            channel = self._channels.get(topic)
            if channel is None:
                if len(self._channels) >= MAX_CHANNELS:
                    self.lost += 1
                    return
                channel = self._writer.register_channel(topic, "json", self._schema)
                self._channels[topic] = channel
            self._writer.add_message(channel, stamp, data, stamp)
            self.written += 1
        except Exception:  # a full disk: the session goes on without its record, the rest counted as lost
            logger.exception("the session recording to %s failed; recording stops", self.path)
            self._failed = True

    def close(self) -> None:
        """Write what is queued, the summary and the footer (blocking: off the event loop)."""
        if self._thread is None or self._writer is None or self._file is None:
            return
        self._closing.set()
        self._thread.join()
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._file.close()
        logger.info(
            "session recorded to %s: %d messages, %d dropped (queue full), %d lost (writer)",
            self.path, self.written, self.dropped, self.lost,
        )  # fmt: skip
