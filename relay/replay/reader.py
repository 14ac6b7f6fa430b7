"""A session recording read ahead of playback on a thread of its own (relay/backends/bag/read_ahead.py): the MCAP is
checked when it opens (a finished MCAP, our channels, messages), then read from the playback position in time order,
never whole, its messages turned into the fleet's events (relay/replay/decoding.py)."""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from mcap.reader import SeekingReader

from ..backends.bag.decoding import Payload, _Item
from ..backends.bag.read_ahead import ReadAhead
from ..backends.bag.reader import PREROLL
from ..errors import BackendUnavailable
from .decoding import IN, OUT, SCHEMA_NAME, Key, NotAMessage, decode, operator_names, played_topics, recorded_robots

logger = logging.getLogger(__name__)


class NotASession(ValueError):
    """The file is not a station session that can be replayed; the message says why."""


@dataclass(frozen=True)
class SessionContents:
    """What a session recording holds: its time span (ns of the relay's wall clock), the robots whose poses it has,
    its channels."""

    start_ns: int
    end_ns: int
    robots: frozenset[str]
    topics: frozenset[str]

    @property
    def duration(self) -> float:
        return (self.end_ns - self.start_ns) * 1e-9


class SessionReader(ReadAhead[SessionContents, frozenset[str]]):
    """One session recording; its plan is the robots to play."""

    def __init__(self, path: Path, loop: asyncio.AbstractEventLoop) -> None:
        super().__init__(path.name, str(path), loop)
        self.path = path
        self.contents: SessionContents | None = None
        self._file: IO[bytes] | None = None
        self._reader: SeekingReader | None = None
        self._topics: list[str] = []
        self._warned: set[str] = set()
        #: The recording's operators by client id (its ``operators`` messages), named on their avatars.
        self._names: dict[str, str] = {}

    def _open(self) -> SessionContents:
        try:
            self._file = self.path.open("rb")
        except OSError as exc:
            raise NotASession(exc.strerror or str(exc)) from None
        try:
            try:
                reader = SeekingReader(self._file, validate_crcs=True)
                summary = reader.get_summary()
                header = reader.get_header()
            except Exception as exc:
                raise NotASession(f"not an MCAP file, or a truncated one ({type(exc).__name__}: {exc})") from None
            if summary is None or summary.statistics is None:
                raise NotASession("an MCAP without its summary: truncated, or its recording never finished")
            ours = {
                c.topic
                for c in summary.channels.values()
                if c.message_encoding == "json"
                and (c.topic.startswith(OUT) or c.topic.startswith(IN))
                and getattr(summary.schemas.get(c.schema_id), "name", None) == SCHEMA_NAME
            }
            if header.library != "xr-relay" or not any(t.startswith(OUT) for t in ours):
                raise NotASession(
                    "an MCAP, but not a station session (xr-relay --record-session writes those): "
                    f"it has no /out/ channels of {SCHEMA_NAME} (its library: {header.library or 'unnamed'!r})"
                )
            stats = summary.statistics
            if stats.message_count == 0:
                raise NotASession("a session recording with no messages")
            self._reader = reader
            self.contents = SessionContents(
                stats.message_start_time, stats.message_end_time, frozenset(recorded_robots(ours)), frozenset(ours)
            )
            return self.contents
        except BaseException:
            self._close_file()
            raise

    def _cannot_read(self, exc: BaseException) -> BackendUnavailable:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        return BackendUnavailable(f"{self.shown}: cannot replay this session: {reason}")

    def _close_file(self) -> None:
        if self._file is not None:
            self._file.close()

    def _prepare(self, plan: frozenset[str]) -> None:
        assert self.contents is not None and self._reader is not None
        self._topics = played_topics(self.contents.topics, plan)
        if f"{OUT}operators" in self.contents.topics:
            for _, _, message in self._reader.iter_messages(topics=[f"{OUT}operators"]):
                try:
                    operator_names(message.data, self._names)
                except ValueError as exc:
                    self._warn_once(f"{OUT}operators", exc)

    def _pass(self, plan: frozenset[str], generation: int, start: float) -> None:
        """Read from ``start`` to the end (or until a seek), then mark the end; the state at ``start`` first (the
        latest of each key in the PREROLL before it)."""
        contents, reader = self.contents, self._reader
        assert contents is not None and reader is not None
        target = contents.start_ns + round(start * 1e9)
        first = max(contents.start_ns, target - round(PREROLL * 1e9))
        latest: dict[Key, Payload] = {}

        def flush() -> bool:
            items = [_Item(start, payload) for payload in latest.values()]
            latest.clear()
            return all(self._push(generation, item) for item in items)

        try:
            for _, channel, message in reader.iter_messages(topics=self._topics, starting_at=first):
                if not self._current(generation):  # a seek or stop: abandon this pass
                    return
                log_ns = message.log_time
                if latest and log_ns >= target and not flush():
                    return
                try:
                    decoded = decode(channel.topic, message.data, log_ns * 1e-9, self._names)
                except NotAMessage as exc:
                    self._warn_once(channel.topic, exc)
                    continue
                if decoded is None:
                    continue
                key, event = decoded
                if log_ns < target:
                    latest[key] = event
                elif not self._push(generation, _Item((log_ns - contents.start_ns) * 1e-9, event)):
                    return
        except Exception as exc:  # a corrupt chunk further in: play what could be read
            logger.error("%s: cannot read further: %s; the session ends here", self.shown, exc)
        if flush():
            self._push(generation, _Item(contents.duration, None))

    def _warn_once(self, topic: str, exc: Exception) -> None:
        if topic not in self._warned:
            self._warned.add(topic)
            logger.warning("%s: skipping messages that cannot be read: %s", self.shown, exc)
