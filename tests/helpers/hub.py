"""The hub's side of a client without a socket: a transport that records what it is sent (and can stall)."""

from __future__ import annotations

import asyncio


class RecordingTransport:
    """Records what it is sent; while ``paused`` it blocks like a socket whose peer stopped reading."""

    def __init__(self, paused: bool = False) -> None:
        self.sent: list[tuple[str, bytes]] = []
        self.gate = asyncio.Event()
        if not paused:
            self.gate.set()
        self.closed: tuple[int, str] | None = None

    async def send_text(self, data: bytes) -> None:
        await self.gate.wait()
        self.sent.append(("text", data))

    async def send_binary(self, data: bytes) -> None:
        await self.gate.wait()
        self.sent.append(("binary", data))

    async def close(self, code: int, reason: str) -> None:
        self.closed = (code, reason)


async def settle() -> None:
    for _ in range(20):
        await asyncio.sleep(0)
