"""The alerts table (relay.inspection.alerts keeps alerts in it): raised once, acknowledged once; and the webhooks'
deliveries (relay.inspection.webhooks), one row per attempt.

A part of the store (relay.inspection.store's ``Store`` is one): the same connection, transactions and errors
(relay.inspection.database). Both statements that write are single upserts, so they are atomic on SQLite and
PostgreSQL alike, also when two relays share one PostgreSQL database:

- ``add_alert`` inserts and leaves a row of the same id as it is (``DO NOTHING``): a raise written late, after its
  acknowledgement reached the database first, does not take the acknowledgement back;
- ``acknowledge_alert`` writes the acknowledged record unless the row is acknowledged already (``DO UPDATE ...
  WHERE alerts.acked_by IS NULL``): of two acknowledgements the first wins and the second learns it.
"""

from __future__ import annotations

from .database import Database
from .records import AlertRecord, DeliveryRecord
from .rows import columns, record_of, row_of

_ALERT = columns(AlertRecord)
_DELIVERY = columns(DeliveryRecord)
_ACK = ("acked_by", "acked_at", "ack_note")
#: How long a webhook delivery attempt is kept (seconds): 90 days, a quarter's audit of who was told what.
DELIVERIES_KEPT = 90 * 86400.0
#: Most delivery attempts kept, whatever their age: about 10 MB of rows.
MOST_DELIVERIES = 50_000


class AlertTables(Database):
    """The alerts of the inspection database, and their deliveries to webhooks."""

    def add_alert(self, alert: AlertRecord) -> None:
        """Keep a raised alert; one of that id already there is left as it is."""
        values = row_of(alert)
        self._write(
            f"INSERT INTO alerts ({_ALERT}) VALUES ({', '.join('?' * len(values))}) ON CONFLICT (id) DO NOTHING",
            values,
        )

    def acknowledge_alert(self, alert: AlertRecord) -> AlertRecord | None:
        """Store ``alert`` (acknowledged: ``acked_by`` set) unless its row is acknowledged already; the record as
        stored, or None when someone acknowledged it first. An alert whose raise is not written yet is written
        whole here."""
        values = row_of(alert)
        updates = ", ".join(f"{c} = excluded.{c}" for c in _ACK)
        rows = self._write(
            f"INSERT INTO alerts ({_ALERT}) VALUES ({', '.join('?' * len(values))}) ON CONFLICT (id) DO UPDATE SET "
            f"{updates} WHERE alerts.acked_by IS NULL RETURNING {_ALERT}",
            values,
        )
        return record_of(AlertRecord, rows[0]) if rows else None

    def alert(self, alert_id: str) -> AlertRecord | None:
        rows = self._read(f"SELECT {_ALERT} FROM alerts WHERE id = ?", (alert_id,))
        return record_of(AlertRecord, rows[0]) if rows else None

    def open_alerts(self, limit: int) -> list[AlertRecord]:
        """The newest ``limit`` alerts nobody acknowledged, newest first."""
        rows = self._read(
            f"SELECT {_ALERT} FROM alerts WHERE acked_by IS NULL ORDER BY raised DESC, id DESC LIMIT ?", (limit,)
        )
        return [record_of(AlertRecord, r) for r in rows]

    def alerts(self) -> list[AlertRecord]:
        """Every alert, oldest first (tests, reports)."""
        return [record_of(AlertRecord, r) for r in self._read(f"SELECT {_ALERT} FROM alerts ORDER BY raised, id")]

    # -- webhook deliveries -----------------------------------------------------------------------

    def add_delivery(self, delivery: DeliveryRecord) -> None:
        """Keep a delivery attempt, in the same transaction dropping those older than ``DELIVERIES_KEPT`` seconds
        before it, and the oldest beyond ``MOST_DELIVERIES`` rows (a webhook that fails for months, or an alert
        storm, must not grow the database without bound)."""
        values = row_of(delivery)
        with self._transaction() as cursor:
            cursor.execute(
                self._sql(f"INSERT INTO webhook_deliveries ({_DELIVERY}) VALUES ({', '.join('?' * len(values))})"),
                tuple(values),
            )
            cursor.execute(self._sql("DELETE FROM webhook_deliveries WHERE t < ?"), (delivery.t - DELIVERIES_KEPT,))
            # The row cap: through the index on t, only past the newest MOST_DELIVERIES rows (a few ms at the cap).
            cursor.execute(
                self._sql(
                    "DELETE FROM webhook_deliveries WHERE t < (SELECT t FROM webhook_deliveries "
                    "ORDER BY t DESC LIMIT 1 OFFSET ?)"
                ),
                (MOST_DELIVERIES - 1,),  # the oldest row kept is the MOST_DELIVERIES-th newest
            )

    def deliveries(self, limit: int, alert: str | None = None) -> list[DeliveryRecord]:
        """The newest ``limit`` delivery attempts (of one alert when given), newest first."""
        where, args = ("WHERE alert = ? ", [alert]) if alert is not None else ("", [])
        rows = self._read(
            f"SELECT {_DELIVERY} FROM webhook_deliveries {where}ORDER BY t DESC, attempt DESC, id DESC LIMIT ?",
            [*args, limit],
        )
        return [record_of(DeliveryRecord, r) for r in rows]
