"""Alerts to webhooks: each alert raised or acknowledged is POSTed, signed, to every endpoint that wants it.

robots.yaml's ``inspection.webhooks`` (relay/config/webhooks.py) lists the endpoints. For each event:

- **The request**: ``POST`` of ``{"event": "alert.raised" | "alert.acknowledged", "alert": {...}}`` (the ``alert``
  message's fields without ``identifier``) as JSON, with ``X-XR-Relay-Timestamp`` (Unix seconds, when this attempt
  was sent) and ``X-XR-Relay-Signature: sha256=<hex HMAC-SHA256 of "<timestamp>.<body>" with the secret>``
  (:func:`sign`). A receiver recomputes the signature over the bytes it got and refuses a timestamp over 5 minutes
  old: a recorded request cannot be replayed later (docs/inspection.md has a verifier).
- **Which**: a raised alert goes to endpoints whose ``events`` name its kind, an acknowledgement to those naming
  ``alert.acknowledged``; an endpoint without ``events`` gets both.
- **Delivery** runs in one task per endpoint (a slow or dead one delays no other), from a bounded queue
  (``QUEUE``; when full the oldest event is dropped, and the count logged). An attempt times out after ``TIMEOUT``
  s; a connection error, a timeout or a 5xx is tried again after 1, 2, 4, 8 s, at most ``ATTEMPTS`` attempts within
  ``BUDGET`` s; a 4xx (or a redirect, which is not followed) is not retried: the request itself is wrong.
- **Recorded**: every attempt and its outcome is a row of ``webhook_deliveries`` (relay.inspection.alert_store:
  the endpoint without user, password or query, never the secret), which ``/webhooks/deliveries`` shows.
- **Never in the way**: :meth:`Webhooks.notify` only queues; nothing waits for an endpoint or for the deliveries'
  records but the endpoint's own task, and a database that cannot record is logged, not retried.

``sleep`` and ``monotonic`` are injected, so the tests drive the backoff by hand.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import hmac
import logging
import math
import time
from collections import deque
from collections.abc import Awaitable, Callable, Sequence
from typing import TYPE_CHECKING, Any, Final

import aiohttp
import orjson
from yarl import URL

from .. import __version__
from .records import ALERT_ACKNOWLEDGED, DeliveryRecord, new_id

if TYPE_CHECKING:
    from ..config import Webhook
    from .messages import AlertMessage

logger = logging.getLogger(__name__)

#: Events waiting per endpoint; beyond it the oldest is dropped.
QUEUE: Final = 256
#: Seconds one attempt may take, connecting included.
TIMEOUT: Final = 10.0
#: Attempts per event, the first pause between them (doubling), and the time all of them may span.
ATTEMPTS: Final = 5
FIRST_PAUSE: Final = 1.0
BUDGET: Final = 120.0
#: How old a timestamp a receiver should accept (documented for receivers; the relay signs each attempt anew).
TOLERANCE: Final = 300

Sleep = Callable[[float], Awaitable[None]]
RecordDelivery = Callable[[DeliveryRecord], Awaitable[None]]


def sign(secret: str, timestamp: int, body: bytes) -> str:
    """``sha256=<hex>``: HMAC-SHA256 of ``b"<timestamp>." + body`` with ``secret`` (UTF-8)."""
    mac = hmac.new(secret.encode(), str(timestamp).encode() + b"." + body, hashlib.sha256)
    return f"sha256={mac.hexdigest()}"


def endpoint_name(url: str) -> str:
    """The URL as logs and the deliveries table show it: no user, password, query or fragment (they may hold a
    token)."""
    return str(URL(url).with_user(None).with_password(None).with_query(None).with_fragment(None))


def event_body(event: str, alert: AlertMessage) -> bytes:
    return orjson.dumps({"event": event, "alert": {k: v for k, v in alert.items() if k != "identifier"}})


def wants(webhook: Webhook, event: str, kind: str) -> bool:
    if webhook.events is None:
        return True
    return (ALERT_ACKNOWLEDGED if event == ALERT_ACKNOWLEDGED else kind) in webhook.events


class _Endpoint:
    """One endpoint's queue and the task that delivers from it, one event at a time, in order."""

    def __init__(self, webhook: Webhook, hooks: Webhooks) -> None:
        self.webhook, self.name, self._hooks = webhook, endpoint_name(webhook.url), hooks
        self.queue: deque[tuple[str, str, bytes]] = deque()  # (event, alert id, body)
        self.wake = asyncio.Event()
        self.task: asyncio.Task[None] | None = None
        self.dropped = self.delivered = self.failed = 0
        self.last_failure: str | None = None

    def put(self, event: str, alert: str, body: bytes) -> None:
        if len(self.queue) >= self._hooks.queue_size:
            self.queue.popleft()
            self.dropped += 1
            if math.log10(self.dropped).is_integer():  # 1, 10, 100, ...: the count, without a line per drop
                logger.warning("webhook %s: queue full (%d), oldest event dropped; %d dropped so far",
                               self.name, self._hooks.queue_size, self.dropped)  # fmt: skip
        self.queue.append((event, alert, body))
        self.wake.set()

    async def run(self, session: aiohttp.ClientSession) -> None:
        while True:
            await self.wake.wait()
            self.wake.clear()
            while self.queue:
                event, alert, body = self.queue.popleft()
                try:
                    await self._deliver(session, event, alert, body)
                except asyncio.CancelledError:
                    raise
                except Exception:  # a bug must cost one event, not every later one
                    logger.exception("webhook %s: %s of alert %s failed", self.name, event, alert)

    async def _deliver(self, session: aiohttp.ClientSession, event: str, alert: str, body: bytes) -> None:
        hooks = self._hooks
        started, pause = hooks.monotonic(), FIRST_PAUSE
        for attempt in range(1, hooks.attempts + 1):
            sent = hooks.clock()
            status, detail = await self._post(session, event, body, int(sent))
            last = attempt == hooks.attempts or hooks.monotonic() - started + pause > hooks.budget
            if status is not None and 200 <= status < 300:
                outcome = "delivered"
            elif status is not None and status < 500:
                outcome, detail = "refused", detail or f"HTTP {status}: not retried"
            else:
                outcome = "failed" if last else "retrying"
            if outcome == "delivered":
                self.delivered += 1
                self.last_failure = None
            elif outcome != "retrying":
                self.failed += 1
                self.last_failure = f"{event} of {alert}: {detail}"[:300]
                logger.warning("webhook %s: %s of alert %s not delivered after %d attempt(s): %s",
                               self.name, event, alert, attempt, detail)  # fmt: skip
            await hooks.record(DeliveryRecord(new_id("d", 8), self.name, event, alert, attempt, sent, status, outcome,
                                              detail[:300]))  # fmt: skip
            if outcome != "retrying":
                return
            await hooks.sleep(pause)
            pause *= 2

    async def _post(
        self, session: aiohttp.ClientSession, event: str, body: bytes, timestamp: int
    ) -> tuple[int | None, str]:
        headers = {
            "Content-Type": "application/json",
            "User-Agent": f"xr-relay/{__version__}",
            "X-XR-Relay-Event": event,
            "X-XR-Relay-Timestamp": str(timestamp),
            "X-XR-Relay-Signature": sign(self.webhook.secret, timestamp, body),
        }
        timeout = aiohttp.ClientTimeout(total=self._hooks.timeout)
        try:
            async with session.post(
                self.webhook.url, data=body, headers=headers, timeout=timeout, allow_redirects=False
            ) as response:
                await response.content.read(4096)  # a little of the answer, so that the connection can be reused
                return response.status, "" if response.status < 300 else f"HTTP {response.status}"
        except asyncio.CancelledError:
            raise
        except TimeoutError:
            return None, f"no answer within {self._hooks.timeout:g} s"
        except (aiohttp.ClientError, OSError, ValueError) as exc:  # refused, unreachable, TLS, a malformed answer
            return None, f"{type(exc).__name__}: {exc}"


class Webhooks:
    """Every endpoint of robots.yaml's ``inspection.webhooks``; :meth:`notify` queues, the endpoints' tasks send."""

    def __init__(
        self,
        webhooks: Sequence[Webhook],
        record: RecordDelivery,
        *,
        sleep: Sleep = asyncio.sleep,
        clock: Callable[[], float] = time.time,
        monotonic: Callable[[], float] = time.monotonic,
        queue_size: int = QUEUE,
        timeout: float = TIMEOUT,
        attempts: int = ATTEMPTS,
        budget: float = BUDGET,
    ) -> None:
        self._record, self.sleep, self.clock, self.monotonic = record, sleep, clock, monotonic
        self.queue_size, self.timeout, self.attempts, self.budget = queue_size, timeout, attempts, budget
        self.endpoints = [_Endpoint(webhook, self) for webhook in webhooks]
        self._session: aiohttp.ClientSession | None = None
        self._record_failure: str | None = None

    def notify(self, event: str, alert: AlertMessage) -> None:
        """Queue ``event`` of ``alert`` for every endpoint that wants it; returns at once."""
        wanting = [e for e in self.endpoints if wants(e.webhook, event, alert["kind"])]
        if wanting:
            body = event_body(event, alert)
            for endpoint in wanting:
                endpoint.put(event, alert["alert"], body)

    async def record(self, delivery: DeliveryRecord) -> None:
        """Store one attempt; a database that fails is logged (once per streak), and delivery goes on."""
        try:
            await self._record(delivery)
        except asyncio.CancelledError:
            raise
        except Exception as exc:
            if self._record_failure is None:
                logger.error("webhook deliveries cannot be recorded: %s", exc)
            self._record_failure = str(exc)[:300]
            return
        self._record_failure = None

    def start(self) -> None:
        if not self.endpoints:
            return
        self._session = aiohttp.ClientSession()
        loop = asyncio.get_running_loop()
        for endpoint in self.endpoints:
            endpoint.task = loop.create_task(endpoint.run(self._session), name=f"webhook {endpoint.name}")

    async def stop(self) -> None:
        """Cancel the deliveries under way (their attempts so far are recorded) and close the HTTP session; events
        still queued are named in the log, not sent."""
        for endpoint in self.endpoints:
            if endpoint.task is not None:
                endpoint.task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await endpoint.task
                endpoint.task = None
            if endpoint.queue:
                logger.warning("webhook %s: %d event(s) not sent before shutdown", endpoint.name, len(endpoint.queue))
        if self._session is not None:
            await self._session.close()
            self._session = None

    def health(self) -> dict[str, Any]:
        """For ``/healthz``: per endpoint (named without credentials), what waits, was dropped, delivered, failed."""
        return {
            "record_error": self._record_failure,
            "endpoints": [
                {"endpoint": e.name, "queued": len(e.queue), "dropped": e.dropped, "delivered": e.delivered,
                 "failed": e.failed, "last_failure": e.last_failure}
                for e in self.endpoints
            ],
        }  # fmt: skip
