"""One reader thread per bag (relay/backends/bag/read_ahead.py): messages to events, in time order, into a bounded
buffer ahead of playback."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
from collections.abc import Callable
from typing import Any

from ...errors import BackendUnavailable
from ..cloud_intake import CloudIntake
from .binding import BagContents, BagPlan, BagSpec
from .decoding import DEFAULT_TYPESTORE, Key, Payload, _Decoder, _Item, _size
from .read_ahead import ReadAhead

logger = logging.getLogger(__name__)

#: After a seek, the reader starts this much earlier (s) to know the state at the target: the latest pose,
#: scan, sensor values and image, and TF's map->odom (AMCL publishes it at ~10 Hz, with gaps of ~3 s).
PREROLL = 3.0


class _BagReader(ReadAhead[BagContents, BagPlan]):
    """One bag: its reader thread (:class:`ReadAhead`) owning the rosbags reader and the decoder."""

    def __init__(self, spec: BagSpec, loop: asyncio.AbstractEventLoop, clouds: CloudIntake | None = None) -> None:
        super().__init__(spec.path.name, spec.shown, loop)
        self.spec = spec
        self._clouds = clouds
        self.contents: BagContents | None = None
        self._reader: Any = None
        self._deserializers: dict[str, Callable[[bytes], Any]] = {}
        self._decoder: _Decoder | None = None
        self._connections: list[Any] = []

    def _cannot_read(self, exc: BaseException) -> BackendUnavailable:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        return BackendUnavailable(f"{self.spec.shown}: cannot read this bag: {reason}")

    def _close_file(self) -> None:
        if self._reader is not None:
            self._reader.close()

    def _open(self) -> BagContents:
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
            self._reader, self._deserializers = reader, deserializers
            return self.contents
        except BaseException:
            with contextlib.suppress(Exception):
                reader.close()
            raise

    def _prepare(self, plan: BagPlan) -> None:
        reader, deserializers = self._reader, self._deserializers
        decoder = self._decoder = _Decoder(plan, self.spec.shown, self._clouds)
        decodable = [c for c in reader.connections if c.msgtype in deserializers]
        # Static transforms hold for the whole recording, wherever they were recorded: read them first.
        statics = [c for c in decodable if c.topic in decoder.statics]
        if statics:
            for connection, _, raw in reader.messages(connections=statics):
                message = deserializers[connection.msgtype](raw)
                for chain in decoder.statics[connection.topic]:
                    chain.add_static(message)
        self._connections = [c for c in decodable if c.topic in decoder.routes]

    def _pass(self, plan: BagPlan, generation: int, start: float) -> None:
        """Read from ``start`` to the end (or until a seek), then mark the end."""
        contents, decoder = self.contents, self._decoder
        assert contents is not None and decoder is not None
        reader, deserializers, connections = self._reader, self._deserializers, self._connections
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
