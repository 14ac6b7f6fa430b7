"""A connected client as the relay sees it: its identity, role, lanes, rate limit and commands in flight."""

from __future__ import annotations

import asyncio
import itertools
import secrets
from collections.abc import Awaitable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from ..station.hub import Channel
from .freshness import SenderClock
from .protocol import Role
from .ratelimit import TokenBucket

_ids = itertools.count(1)


def new_client_id() -> str:
    """``c<n>-<6 hex>``: short for logs, and not guessable across restarts (the counter restarts, the suffix not)."""
    return f"c{next(_ids)}-{secrets.token_hex(3)}"


class Actor(Protocol):
    """Who a command acts as: a connected client, or the relay acting for a person who is not connected (a schedule's
    runs, relay.inspection.scheduler: ``schedule <name>``, as an operator)."""

    @property
    def client_id(self) -> str: ...

    @property
    def role(self) -> Role: ...


@dataclass
class Client:
    """One connected client."""

    client_id: str
    role: Role
    channel: Channel
    allowance: TokenBucket
    address: str | None = None
    #: The name the client gave (``name``), shown to other operators instead of its id; None until it gives one.
    #: A signed-in client's is its account's, and it cannot give another.
    name: str | None = None
    #: Commands that outlive their frame (snapshots), cancelled when the client goes.
    tasks: set[asyncio.Task[None]] = field(default_factory=set)
    #: The client's clock as its ``cmd_vel.t`` stamps show it: how long each command took to reach the relay.
    sender_clock: SenderClock = field(default_factory=SenderClock)
    #: The account it signed in with (relay/accounts); None: the token's operator, or a tokenless viewer.
    user: str | None = None

    def spawn(self, coro: Awaitable[None]) -> None:
        """Run ``coro`` beside the client's later frames, and cancel it if the client disconnects first."""
        task: asyncio.Task[None] = asyncio.ensure_future(coro)
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)

    def cancel_tasks(self) -> None:
        for task in list(self.tasks):
            task.cancel()


def roster(clients: Mapping[str, Client]) -> dict[str, str]:
    """Client id -> name, of the connected clients that gave one."""
    return {cid: c.name for cid, c in clients.items() if c.name is not None}
