"""One reader thread per bag: messages to events, in time order, into a bounded buffer ahead of playback."""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import contextlib
import functools
import logging
import threading
from collections.abc import Callable
from typing import Any

from ...errors import BackendUnavailable
from .binding import BagContents, BagPlan, BagSpec
from .decoding import DEFAULT_TYPESTORE, Key, Payload, _Decoder, _Item, _size

logger = logging.getLogger(__name__)

#: After a seek, the reader starts this much earlier (s) to know the state at the target: the latest pose,
#: scan, sensor values and image, and TF's map->odom (AMCL publishes it at ~10 Hz, with gaps of ~3 s).
PREROLL = 3.0
#: The reader stays at most this many events, image bytes, or seconds of the recording ahead of playback, and
#: refills once half of that was played: decoding in chunks, at the pace of playback, never the whole bag.
MAX_BUFFERED_ITEMS = 5000
MAX_BUFFERED_BYTES = 64 * 1024 * 1024
MAX_BUFFERED_SECONDS = 10.0


class _BagReader:
    """One bag: its reader thread and the bounded buffer of events it fills ahead of playback.

    ``_cond`` guards ``_buffer``, ``_bytes``, ``_generation``, ``_start``, ``_plan`` and ``_stopped``. The thread
    owns the rosbags reader and the decoder. The loop calls :meth:`play`, :meth:`restart`, :meth:`peek`,
    :meth:`pop` and :meth:`close`, which hold the lock only for a few operations and never wait. Every seek
    starts a new generation: the buffer is emptied and the thread abandons its pass and reads from the target.
    """

    def __init__(self, spec: BagSpec, loop: asyncio.AbstractEventLoop) -> None:
        self.spec = spec
        self.opened: concurrent.futures.Future[BagContents] = concurrent.futures.Future()
        #: Set on the loop when the buffer gains an item after being empty, and on every playback change.
        self.ready = asyncio.Event()
        self.contents: BagContents | None = None
        self._loop = loop
        self._cond = threading.Condition()
        self._buffer: collections.deque[_Item] = collections.deque()
        self._bytes = 0
        self._generation = 0
        self._start = 0.0
        self._plan: BagPlan | None = None
        self._stopped = False
        self._thread = threading.Thread(target=self._run, name=f"bag-{spec.path.name}", daemon=True)

    # -- loop side --------------------------------------------------------------------------------

    def start_thread(self) -> None:
        self._thread.start()

    def play(self, plan: BagPlan, start: float) -> None:
        with self._cond:
            self._plan = plan
            self._start = start
            self._generation += 1
            self._cond.notify_all()

    def restart(self, start: float) -> None:
        """Drop what was read ahead and read again from ``start`` (s from the bag's first message)."""
        with self._cond:
            self._generation += 1
            self._start = start
            self._buffer.clear()
            self._bytes = 0
            self._cond.notify_all()
        self.ready.set()

    def peek(self) -> _Item | None:
        with self._cond:
            return self._buffer[0] if self._buffer else None

    def pop(self) -> None:
        with self._cond:
            if self._buffer:
                self._bytes -= self._buffer.popleft().size
            if self._room(0.5):
                self._cond.notify_all()

    def close(self) -> None:
        with self._cond:
            self._stopped = True
            self._cond.notify_all()

    def join(self, timeout: float) -> None:
        if self._thread.is_alive():
            self._thread.join(timeout)

    # -- reader thread ----------------------------------------------------------------------------

    def _wake(self) -> None:
        # The loop may be closed already at shutdown: then nobody waits.
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self.ready.set)

    def _current(self, generation: int) -> bool:
        return self._generation == generation and not self._stopped

    def _room(self, fraction: float) -> bool:
        """Whether the buffer is below ``fraction`` of its limits (call with ``_cond`` held)."""
        if not self._buffer:
            return True
        ahead = self._buffer[-1].position - self._buffer[0].position
        return (
            len(self._buffer) < MAX_BUFFERED_ITEMS * fraction
            and self._bytes < MAX_BUFFERED_BYTES * fraction
            and ahead < MAX_BUFFERED_SECONDS * fraction
        )

    def _push(self, generation: int, item: _Item) -> bool:
        """Append ``item`` once there is room; False when a seek or stop made this pass obsolete."""
        with self._cond:
            while self._current(generation) and not self._room(1.0):
                self._cond.wait()
            if not self._current(generation):
                return False
            was_empty = not self._buffer
            self._buffer.append(item)
            self._bytes += item.size
        if was_empty:
            self._wake()
        return True

    def _run(self) -> None:
        try:
            reader, deserializers = self._open()
        except Exception as exc:
            reason = " ".join(str(exc).split()) or type(exc).__name__
            self.opened.set_exception(BackendUnavailable(f"{self.spec.shown}: cannot read this bag: {reason}"))
            return
        try:
            assert self.contents is not None
            self.opened.set_result(self.contents)
            with self._cond:
                while self._plan is None and not self._stopped:
                    self._cond.wait()
                plan = self._plan
            if plan is not None:
                self._serve(reader, deserializers, plan)
        except Exception as exc:
            if not self.opened.done():  # start() waits on it: it must always be resolved
                self.opened.set_exception(BackendUnavailable(f"{self.spec.shown}: cannot read this bag: {exc}"))
            logger.exception("%s: the bag reader failed; this recording stops here", self.spec.shown)
        finally:
            with contextlib.suppress(Exception):
                reader.close()

    def _open(self) -> tuple[Any, dict[str, Callable[[bytes], Any]]]:
        # rosbags takes ~0.2 s to import and ~0.4 s to open a bag: both happen here, never on the loop.
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        default = get_typestore(Stores(DEFAULT_TYPESTORE))
        # Definitions stored in the bag (MCAP, rosbag2 >= Iron) win; older bags get Humble's.
        reader = AnyReader([self.spec.path], default_typestore=default)
        reader.open()
        try:
            if reader.message_count == 0:
                raise ValueError("it contains no messages")
            # Reading the first message finds a corrupt start now, rather than as an empty replay later.
            with contextlib.closing(reader.messages()) as messages:
                next(messages, None)
            topics: dict[str, str] = {}
            deserializers: dict[str, Callable[[bytes], Any]] = {}
            for connection in reader.connections:
                topic, msgtype = connection.topic, connection.msgtype
                if topics.setdefault(topic, msgtype) != msgtype:
                    logger.warning(
                        "%s: %s is recorded as two types; only %s is read", self.spec.shown, topic, topics[topic]
                    )
                if msgtype in deserializers:
                    continue
                if msgtype in reader.typestore.fielddefs:
                    deserializers[msgtype] = functools.partial(reader.deserialize, typ=msgtype)
                elif msgtype in default.fielddefs:
                    # The bag defines some types but not this one: ROS 2 Humble's definition stands in.
                    deserializers[msgtype] = functools.partial(default.deserialize_cdr, typename=msgtype)
                else:
                    logger.warning(
                        "%s: %s is %s, which neither the bag nor the ROS 2 Humble type store defines; skipped",
                        self.spec.shown,
                        topic,
                        msgtype,
                    )
            self.contents = BagContents(int(reader.start_time), int(reader.end_time), topics)
            return reader, deserializers
        except BaseException:
            with contextlib.suppress(Exception):
                reader.close()
            raise

    def _serve(self, reader: Any, deserializers: dict[str, Callable[[bytes], Any]], plan: BagPlan) -> None:
        decoder = _Decoder(plan, self.spec.shown)
        decodable = [c for c in reader.connections if c.msgtype in deserializers]
        # Static transforms hold for the whole recording, wherever they were recorded: read them first.
        statics = [c for c in decodable if c.topic in decoder.statics]
        if statics:
            for connection, _, raw in reader.messages(connections=statics):
                message = deserializers[connection.msgtype](raw)
                for chain in decoder.statics[connection.topic]:
                    chain.add_static(message)
        connections = [c for c in decodable if c.topic in decoder.routes]
        done = 0
        while True:
            with self._cond:
                while not self._stopped and self._generation == done:
                    self._cond.wait()
                if self._stopped:
                    return
                generation, start = self._generation, self._start
            self._pass(reader, deserializers, decoder, connections, generation, start)
            done = generation

    def _pass(
        self,
        reader: Any,
        deserializers: dict[str, Callable[[bytes], Any]],
        decoder: _Decoder,
        connections: list[Any],
        generation: int,
        start: float,
    ) -> None:
        """Read from ``start`` to the end (or until a seek), then mark the end."""
        contents = self.contents
        assert contents is not None
        decoder.reset()
        target = contents.start_ns + round(start * 1e9)
        first = max(contents.start_ns, target - round(PREROLL * 1e9))
        latest: dict[Key, Payload] = {}  # the state at the target, from the preroll

        def flush() -> bool:
            items = [_Item(start, payload, _size(payload)) for payload in latest.values()]
            latest.clear()
            return all(self._push(generation, item) for item in items)

        try:
            with contextlib.closing(reader.messages(connections=connections, start=first)) as messages:
                for connection, log_ns, raw in messages:
                    if not self._current(generation):  # a seek or stop: abandon this pass
                        return
                    if latest and log_ns >= target and not flush():
                        return
                    try:
                        message = deserializers[connection.msgtype](raw)
                    except Exception as exc:
                        decoder.warn_once(connection.topic, "cannot decode a message of", exc)
                        continue
                    for key, payload in decoder.decode(connection.topic, message, log_ns * 1e-9):
                        if log_ns < target:
                            latest[key] = payload
                        elif not self._push(
                            generation, _Item((log_ns - contents.start_ns) * 1e-9, payload, _size(payload))
                        ):
                            return
        except Exception as exc:  # a corrupt chunk further in: play what could be read
            logger.error("%s: cannot read further: %s; the recording ends here", self.spec.shown, exc)
        if flush():
            self._push(generation, _Item(contents.duration, None))
