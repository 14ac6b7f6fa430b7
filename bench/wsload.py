"""The load-generating WebSocket client every benchmark uses, for every server (xr-relay, the naive relay,
Foxglove's server): one code path, so that differences are the servers'.

It is a bare RFC 6455 client on an asyncio ``Protocol`` rather than the ``websockets`` library: with up
to 50 clients receiving thousands of messages a second in one process that shares 2 cores with the server,
the client's own cost per message must stay a few microseconds, or the benchmark measures the client.
Server frames are unmasked, so receiving is slicing; the pose's ``stamp`` is read with a byte search, not
a JSON parse. Receive times are taken once per ``data_received`` call (every frame in one read arrived
together).

Also here: the *stalled* client (a raw socket that completes the handshake and then never reads).
"""

from __future__ import annotations

import array
import asyncio
import base64
import os
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import orjson

from relay.cloud.blocks_wire import MAGIC as MAP_MAGIC

#: Foxglove's WebSocket subprotocol (the SDK refuses a handshake without it).
FOXGLOVE_SUBPROTOCOL = "foxglove.sdk.v1"
_STAMP = b'"stamp":'
_POSE = b'/pose"'
_SCAN = b'/scan"'
_MESSAGE = b'{"identifier":'


def handshake_request(host: str, port: int, path: str, subprotocol: str | None = None) -> bytes:
    key = base64.b64encode(os.urandom(16)).decode()
    lines = [
        f"GET {path} HTTP/1.1",
        f"Host: {host}:{port}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        f"Sec-WebSocket-Key: {key}",
        "Sec-WebSocket-Version: 13",
    ]
    if subprotocol:
        lines.append(f"Sec-WebSocket-Protocol: {subprotocol}")
    return ("\r\n".join(lines) + "\r\n\r\n").encode()


def masked_frame(payload: bytes, opcode: int = 1) -> bytes:
    """A client frame (clients must mask, RFC 6455 5.3)."""
    mask = os.urandom(4)
    length = len(payload)
    if length < 126:
        head = struct.pack("!BB", 0x80 | opcode, 0x80 | length)
    elif length < 65536:
        head = struct.pack("!BBH", 0x80 | opcode, 0x80 | 126, length)
    else:
        head = struct.pack("!BBQ", 0x80 | opcode, 0x80 | 127, length)
    key = int.from_bytes((mask * (length // 4 + 1))[:length], "big") if length else 0
    body = (int.from_bytes(payload, "big") ^ key).to_bytes(length, "big") if length else b""
    return head + mask + body


def read_stamp(payload: bytes, start: int = 0) -> float | None:
    """The ``stamp`` of a pose message, or None when ``payload`` is not a pose."""
    if payload.find(_POSE, start, start + 64) < 0:
        return None
    i = payload.find(_STAMP, start, start + 96)
    if i < 0:
        return None
    j = i + len(_STAMP)
    end = payload.find(b",", j)
    return float(payload[j:end])


@dataclass
class Recorder:
    """What a group of clients measured; latencies only while ``active`` (the measuring window)."""

    active: bool = False
    pose_latency: array.array[float] = field(default_factory=lambda: array.array("d"))
    frame_latency: array.array[float] = field(default_factory=lambda: array.array("d"))
    frame_bytes: array.array[float] = field(default_factory=lambda: array.array("d"))

    def reset(self) -> None:
        self.pose_latency = array.array("d")
        self.frame_latency = array.array("d")
        self.frame_bytes = array.array("d")


class WsClient(asyncio.Protocol):
    """One connection. ``kind`` is ``xr`` (xr-relay and the naive relay) or ``foxglove``."""

    def __init__(
        self,
        recorder: Recorder,
        *,
        host: str,
        port: int,
        path: str,
        kind: str = "xr",
        on_hello: Callable[[WsClient], None] | None = None,
    ) -> None:
        self.recorder = recorder
        self.kind = kind
        self._request = handshake_request(host, port, path, FOXGLOVE_SUBPROTOCOL if kind == "foxglove" else None)
        self._on_hello = on_hello
        self.transport: asyncio.Transport | None = None
        self._buffer = bytearray()
        self._upgraded = False
        self._fragments: list[bytes] = []
        self._fragment_opcode = 0
        loop = asyncio.get_running_loop()
        self.hello: asyncio.Future[float] = loop.create_future()
        # A client that dies before its hello is reported by whoever waits for it; nobody else needs to.
        self.hello.add_done_callback(lambda f: f.cancelled() or f.exception())
        self.closed: asyncio.Future[None] = loop.create_future()
        self.started = time.monotonic()
        # Counted only while the recorder is active.
        self.poses = 0
        self.scans = 0
        self.frames = 0
        self.bytes = 0
        self.map_bytes = 0  # the 3D map's block records received
        self.frames_by_id: dict[str, int] = {}

    # -- asyncio.Protocol -------------------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        transport.write(self._request)

    def connection_lost(self, exc: Exception | None) -> None:
        if not self.closed.done():
            self.closed.set_result(None)
        if not self.hello.done():
            self.hello.set_exception(ConnectionError(f"closed before hello: {exc}"))

    def data_received(self, data: bytes) -> None:
        now = time.monotonic()
        if self.recorder.active:
            self.bytes += len(data)
        buffer = self._buffer
        buffer += data
        if not self._upgraded:
            end = buffer.find(b"\r\n\r\n")
            if end < 0:
                return
            status = bytes(buffer[: buffer.find(b"\r\n")])
            if b" 101 " not in status:
                if not self.hello.done():
                    self.hello.set_exception(ConnectionError(f"handshake refused: {status.decode(errors='replace')}"))
                assert self.transport is not None
                self.transport.close()
                return
            self._upgraded = True
            del buffer[: end + 4]
        pos = 0
        size = len(buffer)
        while size - pos >= 2:
            b0 = buffer[pos]
            length = buffer[pos + 1] & 0x7F
            head = 2
            if length == 126:
                if size - pos < 4:
                    break
                length = (buffer[pos + 2] << 8) | buffer[pos + 3]
                head = 4
            elif length == 127:
                if size - pos < 10:
                    break
                length = int.from_bytes(buffer[pos + 2 : pos + 10], "big")
                head = 10
            end = pos + head + length
            if end > size:
                break
            payload = bytes(buffer[pos + head : end])
            pos = end
            opcode = b0 & 0x0F
            if not b0 & 0x80 or opcode == 0:  # fragmented (no server here does it, but be correct)
                if opcode:
                    self._fragment_opcode = opcode
                self._fragments.append(payload)
                if not b0 & 0x80:
                    continue
                payload, opcode = b"".join(self._fragments), self._fragment_opcode
                self._fragments = []
            self._frame(opcode, payload, now)
        if pos:
            del buffer[:pos]

    # -- frames -----------------------------------------------------------------------------------

    def _frame(self, opcode: int, payload: bytes, now: float) -> None:
        if opcode == 1:
            self._text(payload, now)
        elif opcode == 2:
            self._binary(payload, now)
        elif opcode == 9 and self.transport is not None:  # ping: the server's heartbeat needs a pong
            self.transport.write(masked_frame(payload, 10))
        elif opcode == 8 and self.transport is not None:
            self.transport.close()

    def _text(self, payload: bytes, now: float) -> None:
        if self.kind == "foxglove":
            message = orjson.loads(payload)
            if message.get("op") == "advertise":
                # Subscribe to every channel: the same data the xr clients get.
                subscriptions = [{"id": c["id"], "channelId": c["id"]} for c in message["channels"]]
                self.send(orjson.dumps({"op": "subscribe", "subscriptions": subscriptions}))
                self._hello(now)
            return
        if payload.startswith(b'{"identifier"') and payload.find(b'"hello"', 0, 40) > 0:
            self._hello(now)
            return
        if not self.recorder.active:
            return
        # A batch (xr-relay with batch=1, a JSON array) holds several messages, every one of them arrived now.
        start = payload.find(_MESSAGE) if payload[:1] == b"[" else 0
        while start >= 0:
            stamp = read_stamp(payload, start)
            if stamp is not None:
                self.poses += 1
                self.recorder.pose_latency.append(now - stamp)
            elif payload.find(_SCAN, start, start + 64) >= 0:
                self.scans += 1
            start = payload.find(_MESSAGE, start + len(_MESSAGE)) if payload[:1] == b"[" else -1

    def _binary(self, payload: bytes, now: float) -> None:
        if self.kind == "foxglove":
            # opcode 1 (message data): u8 op, u32 subscription, u64 log time, then the pose's JSON bytes.
            if payload[0] == 1 and self.recorder.active:
                stamp = read_stamp(payload, 13)
                if stamp is not None:
                    self.poses += 1
                    self.recorder.pose_latency.append(now - stamp)
            return
        if payload[:4] == MAP_MAGIC:  # the live 3D map's block records (docs/protocol.md), not a camera's
            self.map_bytes += len(payload)
            return
        # xr-relay camera frame: u32 header length, JSON header, JPEG.
        if not self.recorder.active:
            return
        (length,) = struct.unpack_from(">I", payload)
        header = orjson.loads(payload[4 : 4 + length])
        self.frames += 1
        identifier = header["identifier"]
        self.frames_by_id[identifier] = self.frames_by_id.get(identifier, 0) + 1
        self.recorder.frame_latency.append(now - float(header["stamp"]))
        self.recorder.frame_bytes.append(len(payload) - 4 - length)

    def _hello(self, now: float) -> None:
        if not self.hello.done():
            self.hello.set_result(now)
            if self._on_hello is not None:
                self._on_hello(self)

    # -- sending ----------------------------------------------------------------------------------

    def send(self, payload: bytes) -> None:
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(masked_frame(payload))

    def reset_counts(self) -> None:
        self.poses = self.scans = self.frames = self.bytes = 0
        self.frames_by_id = {}

    def close(self) -> None:
        if self.transport is not None and not self.transport.is_closing():
            # A close frame then the socket: servers see a clean goodbye.
            self.transport.write(masked_frame(struct.pack("!H", 1000), 8))
            self.transport.close()


async def connect(
    recorder: Recorder,
    port: int,
    *,
    path: str = "/ws",
    kind: str = "xr",
    host: str = "127.0.0.1",
    within: float = 10.0,
    on_hello: Callable[[WsClient], None] | None = None,
) -> WsClient:
    """Open one client and wait for its ``hello`` (Foxglove: its channel advertisement)."""
    loop = asyncio.get_running_loop()
    _, client = await loop.create_connection(
        lambda: WsClient(recorder, host=host, port=port, path=path, kind=kind, on_hello=on_hello), host, port
    )
    await asyncio.wait_for(asyncio.shield(client.hello), within)
    return client


async def connect_many(
    recorder: Recorder, port: int, count: int, *, path: str = "/ws", kind: str = "xr"
) -> list[WsClient]:
    # A few at a time: a burst of handshakes is benchmark 4's subject, not this one's.
    clients: list[WsClient] = []
    for start in range(0, count, 10):
        batch = await asyncio.gather(
            *(connect(recorder, port, path=path, kind=kind) for _ in range(min(10, count - start)))
        )
        clients.extend(batch)
    return clients


def close_all(clients: list[WsClient]) -> None:
    for client in clients:
        client.close()


class StalledClient:
    """Connects, completes the WebSocket handshake, optionally sends commands, then never reads again.

    A plain blocking socket with a small receive buffer: once the kernel's buffers fill, the server's
    writes to it block, which is what a frozen headset on a bad Wi-Fi looks like to the relay.
    """

    def __init__(self, port: int, path: str, commands: list[bytes], host: str = "127.0.0.1") -> None:
        self.sock = socket.create_connection((host, port), timeout=5.0)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 16384)
        self.sock.sendall(handshake_request(host, port, path))
        response = b""
        while b"\r\n\r\n" not in response:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("the server closed the stalled client during its handshake")
            response += chunk
        if b" 101 " not in response.split(b"\r\n", 1)[0]:
            raise ConnectionError(f"handshake refused: {response[:80]!r}")
        for command in commands:
            self.sock.sendall(masked_frame(command))

    def close(self) -> None:
        self.sock.close()
