"""A small test client over a real WebSocket connection (the `websockets` library)."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import math
import time
from collections.abc import Callable
from typing import Any

import orjson
from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed

from relay.station.messages import decode_frame


class TestClient:
    """Collects every message it receives; waits for conditions on them."""

    __test__ = False  # not a pytest test class

    def __init__(self, ws: ClientConnection) -> None:
        self.ws = ws
        self.messages: list[tuple[float, dict[str, Any]]] = []
        self.frames: list[tuple[float, dict[str, Any], bytes]] = []
        #: Binary frames of the 3D map's block records (docs/protocol.md, "Voxel map blocks"), as received.
        self.voxel_frames: list[bytes] = []
        self.latest: dict[str, dict[str, Any]] = {}
        #: The size of every batch received (text frames that were JSON arrays).
        self.batches: list[int] = []
        self._changed = asyncio.Event()
        self._ids = itertools.count(1)
        self._reader = asyncio.get_running_loop().create_task(self._read())
        self.closed_code: int | None = None

    @classmethod
    async def open(cls, url: str, **kwargs: Any) -> TestClient:
        ws = await connect(url, max_size=8 * 1024 * 1024, **kwargs)
        return cls(ws)

    async def _read(self) -> None:
        try:
            async for data in self.ws:
                now = time.monotonic()
                if isinstance(data, bytes) and data[:4] == b"XRVB":
                    self.voxel_frames.append(data)
                elif isinstance(data, bytes):
                    header, payload = decode_frame(data)
                    self.frames.append((now, header, payload))
                else:
                    parsed = orjson.loads(data)
                    if isinstance(parsed, list):  # a batch (the client connected with batch=1)
                        self.batches.append(len(parsed))
                    for message in parsed if isinstance(parsed, list) else [parsed]:
                        self.messages.append((now, message))
                        key = message["identifier"]
                        if key.endswith("/sensor"):
                            key = f"{key}/{message['name']}"
                        self.latest[key] = message
                self._changed.set()
        except ConnectionClosed:
            pass  # the relay went away without a closing handshake (killed): closed_code says so
        finally:
            self.closed_code = self.ws.close_code
            self._changed.set()

    def next_id(self) -> str:
        return f"t{next(self._ids)}"

    async def send(self, message: dict[str, Any]) -> None:
        await self.ws.send(orjson.dumps(message).decode())

    async def send_raw(self, data: str | bytes) -> None:
        await self.ws.send(data)

    async def wait_for(
        self, predicate: Callable[[dict[str, Any]], bool], timeout: float = 5.0, start: int = 0
    ) -> dict[str, Any]:
        """The first message (from index ``start``) matching ``predicate``."""
        deadline = time.monotonic() + timeout
        index = start
        while True:
            while index < len(self.messages):
                message = self.messages[index][1]
                index += 1
                if predicate(message):
                    return message
            remaining = deadline - time.monotonic()
            if remaining <= 0 or self._reader.done():
                raise TimeoutError(f"no matching message within {timeout} s; last: {self.messages[-3:]}")
            self._changed.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._changed.wait(), remaining)

    async def request(
        self, message: dict[str, Any], timeout: float = 5.0, *, resend_stale: bool = True
    ) -> dict[str, Any]:
        """Send a command with a fresh id; return its ack or error. A motion command the relay dropped as ``stale``
        is sent again (twice at most, as an operator would): a relay whose loop a loaded machine starved just as the
        frame came in dates it to the stall's start (relay/net/loop_lag.py), which is right, and not what the test is
        about; ``resend_stale=False`` returns that error."""
        for _ in range(3):
            reply = await self._request_once(message, timeout)
            if not resend_stale or reply.get("code") != "stale":
                break
        return reply

    async def _request_once(self, message: dict[str, Any], timeout: float) -> dict[str, Any]:
        rid = self.next_id()
        start = len(self.messages)
        await self.send({**message, "id": rid})
        return await self.wait_for(lambda m: m["identifier"] in ("ack", "error") and m.get("id") == rid, timeout, start)

    async def hello(self) -> dict[str, Any]:
        return await self.wait_for(lambda m: m["identifier"] == "hello")

    def targets(self) -> dict[str, dict[str, Any]]:
        """The site's targets by id as this client knows them: the `targets` list, then every `targets_changed`."""
        known: dict[str, dict[str, Any]] = {}
        for _, message in self.messages:
            if message["identifier"] == "targets":
                known = {t["id"]: t for t in message["targets"]}
            elif message["identifier"] == "targets_changed":
                for target_id in message["removed"]:
                    known.pop(target_id, None)
                known.update((t["id"], t) for t in message["added"])
        return known

    def pose(self, robot: str) -> dict[str, Any] | None:
        return self.latest.get(f"{robot}/pose")

    async def wait_pose_near(self, robot: str, x: float, y: float, tolerance: float, timeout: float) -> dict[str, Any]:
        return await self.wait_for(
            lambda m: m["identifier"] == f"{robot}/pose" and math.hypot(m["x"] - x, m["y"] - y) <= tolerance,
            timeout,
        )

    async def close(self) -> None:
        await self.ws.close()
        await self._reader
