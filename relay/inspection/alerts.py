"""Alerts: what a person must see and acknowledge, raised by the relay through one function, kept in the database.

- **Raised** by :meth:`Alerts.raise_alert` (kind, text, robot, subject, severity): a finding made as or changed to
  ``anomaly`` or ``changed`` (a place that changed since its last round: kind ``changed``), a capture's reading
  past its limit that no such finding names, a mission aborted; later kinds (a scheduled run that failed or was
  missed, a robot offline mid-run) call the same function. Raising awaits nothing:
  the alert is in memory and sent to every client at once, then stored (relay.inspection.write_behind) and handed to
  the webhooks (relay.inspection.webhooks), so it may be raised from any path, and nothing of an estop waits for it.
- **Kept**: the newest ``ALERTS_ON_CONNECT`` unacknowledged ones in memory (loaded from the database at start), sent
  to every client after its ``hello``; older ones stay in the database and may still be acknowledged.
- **Acknowledged** by ``alert/ack`` (operators): the operator's name, the time and a note are stored first (one
  conditional upsert, relay.inspection.alert_store: of two acknowledgements the first wins), then every client gets
  the alert again with ``acknowledged`` set and drops it from its list. An unknown alert, or one acknowledged
  already, is a ``bad_request`` naming it, and nothing changes. The audit log records the command with the name.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

from ..errors import CommandRejected
from ..session.protocol import ErrorCode, RequestId
from .messages import ALERTS_ON_CONNECT, AlertMessage, alert_message
from .records import ALERT_ACKNOWLEDGED, AlertRecord, AlertSeverity, new_id
from .wire import AlertAck
from .write_behind import WriteBehind

if TYPE_CHECKING:
    from ..session.clients import Client
    from ..station.outbox import Outbox
    from .storage import Storage
    from .store import Store

logger = logging.getLogger(__name__)

#: Longest text an alert keeps (it names a target, a robot and a few readings).
MAX_TEXT = 500
#: The events handed to the webhooks: an alert raised, an alert acknowledged.
RAISED = "alert.raised"
ACKNOWLEDGED = ALERT_ACKNOWLEDGED

#: Told of each alert raised or acknowledged: (event, the alert as clients see it). The webhooks' ``notify``.
Notify = Callable[[str, AlertMessage], None]


class Alerts:
    def __init__(
        self,
        outbox: Outbox,
        storage: Storage,
        notify: Notify,
        *,
        wall_clock: Callable[[], float] = time.time,
        limit: int = ALERTS_ON_CONNECT,
    ) -> None:
        self._outbox, self._storage, self._notify, self._wall, self._limit = outbox, storage, notify, wall_clock, limit
        #: The unacknowledged alerts in memory, oldest first: the newest ``limit``.
        self._open: dict[str, AlertRecord] = {}
        self._writes: WriteBehind[AlertRecord] = WriteBehind(self._save, "alerts")

    # -- lifecycle --------------------------------------------------------------------------------

    async def start(self, store: Store) -> None:
        """The unacknowledged alerts of the database (the newest ``limit``), and the writer that stores new ones."""
        found = await self._storage.run(lambda: store.open_alerts(self._limit))
        self._open = {alert.id: alert for alert in reversed(found)}
        self._writes.start()

    async def close(self) -> None:
        await self._writes.close()

    @property
    def failure(self) -> str | None:
        """Why alerts wait to be stored (``/healthz``), or None."""
        return self._writes.failure

    @property
    def open(self) -> list[AlertRecord]:
        """The unacknowledged alerts in memory, oldest first."""
        return list(self._open.values())

    def on_connect(self, client: Client) -> None:
        for alert in self._open.values():
            self._outbox.to(client, alert_message(alert))

    # -- raising ----------------------------------------------------------------------------------

    def raise_alert(
        self,
        kind: str,
        text: str,
        *,
        robot: str | None = None,
        subject: str | None = None,
        severity: AlertSeverity = "warning",
    ) -> AlertRecord:
        """Raise an alert: every client gets it now; it is stored and sent to the webhooks after. Awaits nothing."""
        alert = AlertRecord(new_id("a", 8), kind, robot, subject, text[:MAX_TEXT], severity, self._wall())
        self._open[alert.id] = alert
        while len(self._open) > self._limit:  # the oldest leaves memory; the database keeps it, unacknowledged
            del self._open[next(iter(self._open))]
        message = alert_message(alert)
        self._outbox.broadcast(message)
        self._writes.put(alert)
        self._notify(RAISED, message)
        logger.info("alert %s (%s, %s): %s", alert.id, kind, severity, alert.text)
        return alert

    async def _save(self, alert: AlertRecord) -> None:
        store = self._storage.store
        if store is not None:
            await self._storage.run(lambda: store.add_alert(alert))

    # -- acknowledging ----------------------------------------------------------------------------

    async def acknowledge(self, client: Client, command: AlertAck) -> None:
        """``alert/ack``: stored first (CommandRejected naming the database when it cannot be), then announced."""
        alert_id = command.alert
        alert = self._open.get(alert_id)
        if alert is None:  # older than what memory holds, acknowledged already, or unknown: the database knows
            alert = await self._storage.call(lambda s: s.alert(alert_id), command.id)
            if alert is None:
                raise CommandRejected(ErrorCode.BAD_REQUEST, f"alert/ack: no alert {alert_id[:80]!r}", command.id)
            if alert.acked_by is not None:
                raise _already(alert, command.id)
        by = client.name or client.client_id
        acked = replace(alert, acked_by=by, acked_at=self._wall(), ack_note=command.note or "")
        stored = await self._storage.call(lambda s: s.acknowledge_alert(acked), command.id)
        if stored is None:  # another operator's acknowledgement reached the database first
            self._open.pop(alert_id, None)
            current = await self._storage.call(lambda s: s.alert(alert_id), command.id)
            raise _already(current or acked, command.id)
        self._open.pop(alert_id, None)
        message = alert_message(stored)
        self._outbox.broadcast(message)
        self._notify(ACKNOWLEDGED, message)
        logger.info("alert %s acknowledged by %s (%s)", alert_id, by, client.client_id)


def _already(alert: AlertRecord, request_id: RequestId) -> CommandRejected:
    when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(alert.acked_at or 0.0))
    return CommandRejected(
        ErrorCode.BAD_REQUEST,
        f"alert/ack: alert {alert.id} was acknowledged already, by {alert.acked_by} at {when}",
        request_id,
    )
