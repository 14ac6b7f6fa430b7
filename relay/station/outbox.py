"""What the relay tells its clients, each message encoded once: the one way a message leaves the relay.

Every part sends through here (:meth:`Outbox.to` one client, :meth:`Outbox.broadcast` every client), and the lane
a message takes is decided here, by its kind: the state kinds (poses, sensors, statuses, scans, navigation,
paths, the scene, playback) are latest-value state, coalesced for a slow client; every other message (replies,
and what an operator must learn before the rest of their queue: ``estop``, ``<robot>/lease``, ``<robot>/model``,
``backend``, missions and findings) takes the priority lane. Camera frames are media: relay.media.streams sends them
on their own lanes, except a snapshot's picture, which is a reply (:meth:`Outbox.frame`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from typing import Any, Final, cast

from ..fleet.state import FleetState
from ..session.clients import Client
from ..session.protocol import RequestId
from .hub import Channel, Hub
from .messages import (
    LeaseReason,
    ServerMessage,
    StateMessage,
    ack_message,
    backend_message,
    encode,
    error_message,
    estop_message,
    lease_message,
    operators_message,
    state_key,
)

logger = logging.getLogger(__name__)

#: The kinds a client keeps only the newest of (relay/station/hub.py's state lane, per ``state_key``).
STATE_KINDS: Final = frozenset(
    {"pose", "sensor", "status", "scan", "nav", "path", "scene", "playback", "joints", "avatar", "valve"}
)


def is_state(message: ServerMessage | Mapping[str, Any]) -> bool:
    """Whether a message is latest-value state (its identifier's kind, ``robot1/pose`` or ``scene``)."""
    identifier = str(message["identifier"])
    return identifier.rpartition("/")[2] in STATE_KINDS


#: Where a copy of every JSON message goes when the session is recorded: ``record(topic, data)``, never blocking
#: (relay/replay/recorder.py). Topics: ``/out/<identifier>`` for what every client gets, ``/out/<client id>`` for a
#: client's own replies.
Record = Callable[[str, bytes], None]


class Outbox:
    def __init__(self, hub: Hub, fleet: FleetState, record: Record | None = None) -> None:
        self.hub = hub
        self.fleet = fleet
        self.record = record
        #: Whether each robot was online in the last status sent, so that a change is announced at once.
        self._was_online: dict[str, bool] = {}

    # -- the two ways out --------------------------------------------------------------------------

    def to(self, client: Client, message: ServerMessage) -> None:
        """One message to one client, in the lane of its kind."""
        data = encode(message)
        if self.record is not None:
            self.record(f"/out/{client.client_id}", data)
        if is_state(message):
            client.channel.put_state(state_key(cast(StateMessage, message)), data)
        else:
            client.channel.put_priority(data)

    def broadcast(self, message: ServerMessage) -> None:
        """One message to every client, encoded once, in the lane of its kind."""
        data = encode(message)
        if self.record is not None:
            self.record(f"/out/{message['identifier']}", data)
        if is_state(message):
            self.hub.publish_state(state_key(cast(StateMessage, message)), data)
        else:
            self.hub.broadcast_priority(data)

    def to_channels(self, channels: Iterable[Channel], message: ServerMessage) -> None:
        """One message, encoded once, to the clients of these channels (a camera's viewers)."""
        data = encode(message)
        if self.record is not None:
            self.record(f"/out/{message['identifier']}", data)
        for channel in channels:
            if is_state(message):
                channel.put_state(state_key(cast(StateMessage, message)), data)
            else:
                channel.put_priority(data)

    def frame(self, client: Client, data: bytes) -> None:
        """A snapshot's picture (a binary frame, relay.media.streams encodes it): a reply, ahead of the client's
        queue."""
        client.channel.put_priority(data, binary=True)

    # -- to one client ----------------------------------------------------------------------------

    def ack(self, client: Client, request_id: RequestId) -> None:
        self.to(client, ack_message(request_id))

    def error(self, client: Client, request_id: RequestId | None, code: str, message: str) -> None:
        logger.debug("error to %s: %s %s", client.client_id, code, message)
        self.to(client, error_message(request_id, code, message))

    # -- to every client --------------------------------------------------------------------------

    def state(self, message: StateMessage) -> None:
        """Latest-value state to every client, coalesced under the message's own key."""
        self.broadcast(message)

    def status(self, robot: str, now: float) -> None:
        status = self.fleet.status(robot, now)
        self._was_online[robot] = status["online"]
        self.state(status)

    def online_changed(self, robot: str, now: float) -> bool:
        """Whether ``robot``'s online state differs from what clients were last told."""
        return self._was_online.get(robot, False) != self.fleet.online(robot, now)

    def lease(self, robot: str, holder: str | None, previous: str | None, reason: LeaseReason) -> None:
        # Priority: the operator who lost a robot must learn it before anything else they have queued.
        self.broadcast(lease_message(robot, holder=holder, previous=previous, reason=reason))

    def estop(self, robots: list[str], by: str | None, *, latched: bool = True) -> None:
        self.broadcast(estop_message(robots, by, latched=latched))

    def operators(self, names: Mapping[str, str]) -> None:
        self.broadcast(operators_message(names))

    def backend(self, name: str, failure: str | None) -> None:
        self.broadcast(backend_message(name, failure))
