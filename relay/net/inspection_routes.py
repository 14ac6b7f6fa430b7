"""The inspection's reading routes: capture images, reports and webhook deliveries, for the operator token or a
signed-in person (or anyone when viewers are allowed), refused as if unknown otherwise."""

from __future__ import annotations

import asyncio
import dataclasses
import time

from aiohttp import web

from .access import Refused
from .keys import ACCESS_KEY, RELAY_KEY, SIGN_IN_KEY

#: What /captures and /report answer for what does not exist and for what the request may not read: the same
#: status and words, so that a guesser cannot tell a wrong token from a right one by the answer (it was 401 for a
#: wrong token, 404 for the right one and an unknown mission).
NOT_FOUND = "no such {what}, or not for this token: open it from the relay's page, whose links carry the token\n"


async def may_read_inspection(request: web.Request) -> bool:
    """Capture images and reports: for the operator (the token in ``?token=``), and for anyone when viewers are
    allowed (viewers see findings). Wrong tokens are slowed as at the handshake (``Access.admit``: one count per
    address, shared with /ws and /auth); a refusal is then answered as an unknown name is (``NOT_FOUND``)."""
    access = request.app[ACCESS_KEY]
    try:
        access.check_origin(request.headers.get("Origin"), f"{request.scheme}://{request.host}")
        if request.app[SIGN_IN_KEY].session_of(request) is not None:
            return True  # every signed-in role sees findings
        _, delay = access.admit(request.query.get("token"), request.remote or "unknown", time.monotonic())
    except Refused as exc:
        await asyncio.sleep(exc.delay)
        return False
    if delay > 0:
        await asyncio.sleep(delay)
    return True


async def capture_image(request: web.Request) -> web.Response:
    allowed = await may_read_inspection(request)
    jpeg = await request.app[RELAY_KEY].inspection.image(request.match_info["sha"]) if allowed else None
    if jpeg is None:
        raise web.HTTPNotFound(text=NOT_FOUND.format(what="capture image"))
    return web.Response(body=jpeg, content_type="image/jpeg", headers={"Cache-Control": "private, max-age=86400"})


async def report(request: web.Request) -> web.Response:
    """``/report/<mission>.<kind>`` and ``/report/range.<kind>?from=...&to=...`` (relay.inspection.report);
    ``/report/range.html`` alone asks for a range. A range that cannot be read or holds too much is a 400 saying
    so; what the token may not read, or that does not exist, is ``NOT_FOUND``."""
    from ..inspection import report as reports

    named = reports.split_name(request.match_info["name"]) if await may_read_inspection(request) else None
    if named is None:
        raise web.HTTPNotFound(text=NOT_FOUND.format(what="report"))
    stem, kind = named
    relay = request.app[RELAY_KEY]
    scope = reports.Scope(mission=stem)
    if stem == reports.RANGE:
        asked = reports.asked_range(request.query, kind, relay.config, time.time())
        if not isinstance(asked, reports.Scope):
            status, text = asked
            return web.Response(text=text, status=status, content_type=reports.content_type(kind), charset="utf-8")
        scope = asked
    try:
        text = await relay.inspection.report(scope, kind, f"{request.scheme}://{request.host}")
    except reports.ReportRefused as exc:
        raise web.HTTPBadRequest(text=f"{exc}\n") from None
    except ValueError:
        raise web.HTTPNotFound(text=NOT_FOUND.format(what="report")) from None
    response = web.Response(text=text, content_type=reports.content_type(kind), charset="utf-8")
    if kind != "html":  # a file to keep or import, under a name that says what it holds
        response.headers["Content-Disposition"] = f'attachment; filename="report-{stem}.{kind}"'
    return response


#: Delivery attempts ``/webhooks/deliveries`` shows by default, and at most.
DELIVERIES, MAX_DELIVERIES = 100, 1000


async def webhook_deliveries(request: web.Request) -> web.Response:
    """``/webhooks/deliveries?limit=N``: the newest attempts to deliver alerts to webhooks, newest first, each with
    its outcome (relay.inspection.webhooks), and what each endpoint has queued, dropped, delivered and failed. No
    secret is in either."""
    if not await may_read_inspection(request):
        raise web.HTTPNotFound(text=NOT_FOUND.format(what="page"))
    try:
        limit = int(request.query.get("limit", DELIVERIES))
    except ValueError:
        limit = 0
    if not 1 <= limit <= MAX_DELIVERIES:
        raise web.HTTPBadRequest(text=f"limit: expected a whole number from 1 to {MAX_DELIVERIES}\n")
    inspection = request.app[RELAY_KEY].inspection
    found = await inspection.deliveries(limit)
    body = {**inspection.webhooks.health(), "deliveries": [dataclasses.asdict(d) for d in found]}
    return web.json_response(body, headers={"Cache-Control": "no-store"})
