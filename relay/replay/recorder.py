"""A station session into one MCAP file: what the relay sent (robots' poses, readings and statuses, estops, answers)
and what it was sent (every command, with the client that sent it), each message as the JSON bytes that went over
the wire, on a channel per identifier (``/out/robot1/pose``, ``/in/c3-ab12cd``), stamped with the relay's wall clock.

The event loop never waits for the file: :meth:`SessionRecorder.record` puts the bytes on a bounded queue and a
thread of the recorder's own writes them (MCAP's chunks, zstd-compressed); when the queue is full the message is
dropped and counted (``dropped``, said in the log line when the recording closes), so a disk that stalls costs the
recording, never a stop. JSON messages go in as JSON (MCAP's ``json`` encoding, with a permissive JSON Schema),
which Foxglove and the ``mcap`` library read as they are.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from pathlib import Path
from typing import IO, Final

from mcap.writer import Writer

from ..errors import RecordingError

logger = logging.getLogger(__name__)

#: Messages waiting for the writer at most: 100 robots' poses at 30 Hz for 3 s.
MAX_QUEUE: Final = 10_000
#: The schema every channel shares: a JSON object (the protocol's own schema is docs/protocol.md's).
_SCHEMA: Final = b'{"type": "object"}'
#: Topics per recording at most: identifiers are bounded by the fleet, clients' ids by the connections made.
MAX_CHANNELS: Final = 10_000


class SessionRecorder:
    def __init__(self, path: Path, *, max_queue: int = MAX_QUEUE) -> None:
        self.path = Path(path)
        self.queue: queue.Queue[tuple[str, bytes, int] | None] = queue.Queue(max_queue)  # None: stop
        self.dropped = 0  # by the loop: the queue was full (only the loop adds to it)
        self.lost = 0  # by the writer: past MAX_CHANNELS, or after the file failed (only the writer adds to it)
        self.written = 0
        self._channels: dict[str, int] = {}
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
        """Queue one message for the file; never blocks (a full queue drops it, counted)."""
        try:
            self.queue.put_nowait((topic, data, time.time_ns() if log_time_ns is None else log_time_ns))
        except queue.Full:
            self.dropped += 1

    def _run(self) -> None:
        assert self._writer is not None
        while True:
            item = self.queue.get()
            if item is None:
                return
            topic, data, stamp = item
            try:
                channel = self._channels.get(topic)
                if channel is None:
                    if len(self._channels) >= MAX_CHANNELS:
                        self.lost += 1
                        continue
                    channel = self._writer.register_channel(topic, "json", self._schema)
                    self._channels[topic] = channel
                self._writer.add_message(channel, stamp, data, stamp)
                self.written += 1
            except Exception:  # a full disk: the session goes on without its record
                logger.exception("the session recording to %s failed; recording stops", self.path)
                self._drain()
                return

    def _drain(self) -> None:
        """After a failure: everything queued and to come is dropped, counted, until close."""
        while True:
            if self.queue.get() is None:
                return
            self.lost += 1

    def close(self) -> None:
        """Write what is queued, the summary and the footer (blocking: off the event loop)."""
        if self._thread is None or self._writer is None or self._file is None:
            return
        self.queue.put(None)
        self._thread.join()
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._file.close()
        logger.info(
            "session recorded to %s: %d messages, %d dropped (queue full), %d lost (writer)",
            self.path, self.written, self.dropped, self.lost,
        )  # fmt: skip
