"""What the relay tells its clients: replies, statuses, lease changes and stops, each encoded once.

Everything the command rules, the supervisor and the event routing announce goes through here, so that the
lane each message takes is decided in one place: replies and anything an operator must learn before the rest of
their queue (``estop``, ``<robot>/lease``, ``<robot>/model``, ``backend``) go through the priority lane; statuses
are latest-value state.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

from .clients import Client
from .fleet import FleetState
from .hub import Hub
from .messages import (
    LeaseReason,
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
from .protocol import RequestId

logger = logging.getLogger(__name__)


class Outbox:
    def __init__(self, hub: Hub, fleet: FleetState) -> None:
        self.hub = hub
        self.fleet = fleet
        #: Whether each robot was online in the last status sent, so that a change is announced at once.
        self._was_online: dict[str, bool] = {}

    # -- to one client ----------------------------------------------------------------------------

    def ack(self, client: Client, request_id: RequestId) -> None:
        client.channel.put_priority(encode(ack_message(request_id)))

    def error(self, client: Client, request_id: RequestId | None, code: str, message: str) -> None:
        logger.debug("error to %s: %s %s", client.client_id, code, message)
        client.channel.put_priority(encode(error_message(request_id, code, message)))

    # -- to every client --------------------------------------------------------------------------

    def state(self, message: StateMessage) -> None:
        """Latest-value state to every client, coalesced under the message's own key."""
        self.hub.publish_state(state_key(message), encode(message))

    def status(self, robot: str, now: float) -> None:
        status = self.fleet.status(robot, now)
        self._was_online[robot] = status["online"]
        self.state(status)

    def online_changed(self, robot: str, now: float) -> bool:
        """Whether ``robot``'s online state differs from what clients were last told."""
        return self._was_online.get(robot, False) != self.fleet.online(robot, now)

    def lease(self, robot: str, holder: str | None, previous: str | None, reason: LeaseReason) -> None:
        # Priority: the operator who lost a robot must learn it before anything else they have queued.
        self.hub.broadcast_priority(encode(lease_message(robot, holder=holder, previous=previous, reason=reason)))

    def estop(self, robots: list[str], by: str | None, *, latched: bool = True) -> None:
        self.hub.broadcast_priority(encode(estop_message(robots, by, latched=latched)))

    def operators(self, names: Mapping[str, str]) -> None:
        self.hub.broadcast_priority(encode(operators_message(names)))

    def backend(self, name: str, failure: str | None) -> None:
        self.hub.broadcast_priority(encode(backend_message(name, failure)))
