"""HTTP and WebSocket on one port (aiohttp): the static client, the scenes, /ws, /healthz and /metrics (the
inspection's reading routes: relay.net.inspection_routes).

Every background task, socket and the backend belong to the application's lifecycle: the relay starts in a
``cleanup_ctx`` and stops there; on shutdown every robot is stopped first, then every WebSocket is closed
with 1001 GOING_AWAY.
"""

from __future__ import annotations

import asyncio
import logging
import signal
import socket
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from urllib.parse import urlsplit

from aiohttp import WSCloseCode, WSMsgType, web

from .. import __version__
from ..accounts.users import UserBook
from ..cli.options import Options
from ..config import FleetConfig
from ..session.clients import Client
from ..station.core import BackendFactory, Relay
from .access import Access, Refused
from .guard import ConnectionGuard
from .headers import SecurityHeaders
from .inspection_routes import capture_image, report, webhook_deliveries
from .keys import ACCESS_KEY as ACCESS_KEY
from .keys import GUARD_KEY as GUARD_KEY
from .keys import RELAY_KEY as RELAY_KEY
from .keys import SIGN_IN_KEY as SIGN_IN_KEY
from .keys import SOCKETS_KEY as SOCKETS_KEY
from .loop_lag import ArrivalDates, date_reads, unread_bytes
from .oidc import OidcSettings, OidcSignIn
from .oidc import add_routes as add_oidc_routes
from .sign_in import SignIn
from .sign_in import add_routes as add_sign_in_routes
from .tls import fingerprint, server_context

logger = logging.getLogger(__name__)

ROOT = Path(__file__).resolve().parent.parent.parent
CLIENT_DIR = ROOT / "xr_client"
SCENES_DIR = ROOT / "scenes"

#: aiohttp refuses larger frames outright (close 1009); smaller ones over protocol.MAX_TEXT_BYTES get an
#: ``error`` ``too_large`` and the connection stays open.
MAX_FRAME_BYTES = 1024 * 1024
#: Kernel send buffer per WebSocket. Linux autotunes it up to 4 MB, which a client that stops reading would
#: fill before the hub's lanes even notice; 256 kB (the kernel doubles it) still carries a 30 fps camera
#: stream over a LAN round trip of tens of milliseconds.
SOCKET_SEND_BUFFER = 256 * 1024
#: Unsent bytes the kernel holds per WebSocket (TCP_NOTSENT_LOWAT): bytes in flight are limited by the send
#: buffer above, bytes not yet sent by this. Without it a viewer that stops reading (or a network that slows down)
#: took the whole 512 kB before the hub's lanes dropped anything: 1.6 s of a 2.5 Mbit/s video, 3 JPEG frames of
#: 720p, each one a picture that much older (measured: tests/test_video.py). 64 kB is 0.2 s of that video.
UNSENT_BYTES = 64 * 1024
#: asyncio's buffer above the kernel (its default high-water mark is 64 kB and aiohttp looked at it only every
#: 64 kB written): aiohttp's writer waits past this, and checks after every WEBSOCKET_WRITER_LIMIT bytes.
WRITE_BUFFER_BYTES = 32 * 1024
WEBSOCKET_WRITER_LIMIT = 16 * 1024
#: Shutdown budget: Ctrl-C must leave within 2 s, robots stopped and sockets closed.
SHUTDOWN_TIMEOUT = 1.5


class AiohttpTransport:
    """The hub's view of one aiohttp WebSocket."""

    def __init__(self, ws: web.WebSocketResponse) -> None:
        self._ws = ws

    async def send_text(self, data: bytes) -> None:
        # Pre-encoded UTF-8 JSON goes out as a text frame without decoding it again.
        await self._ws.send_frame(data, WSMsgType.TEXT)

    async def send_binary(self, data: bytes) -> None:
        await self._ws.send_frame(data, WSMsgType.BINARY)

    async def close(self, code: int, reason: str) -> None:
        await self._ws.close(code=code, message=reason.encode())


def bound_backlog(transport: asyncio.BaseTransport | None) -> None:
    """Keep what a WebSocket holds for a peer that does not read small, so that the hub's lanes see it at once
    and drop (a JPEG frame, a video stream until its next keyframe) instead of queueing seconds of pictures."""
    if not isinstance(transport, asyncio.WriteTransport):
        return
    transport.set_write_buffer_limits(high=WRITE_BUFFER_BYTES)
    sock = transport.get_extra_info("socket")
    if sock is None or sock.family not in (socket.AF_INET, socket.AF_INET6):
        return
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SOCKET_SEND_BUFFER)
    if hasattr(socket, "TCP_NOTSENT_LOWAT"):  # Linux and macOS; elsewhere the send buffer alone bounds it
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NOTSENT_LOWAT, UNSENT_BYTES)


#: Content types by extension. Explicit because ES modules must be served as JavaScript, glTF has no
#: entry in many systems' mime.types, and aiohttp's own guesser ignores ``mimetypes.add_type``.
CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".map": "application/json",
    ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json",
    ".bin": "application/octet-stream",
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".ktx2": "image/ktx2",
    ".wasm": "application/wasm",
    ".svg": "image/svg+xml",
    ".woff2": "font/woff2",
    ".ttf": "font/ttf",
    ".yaml": "text/plain; charset=utf-8",
}


#: What the page needs from xr_client/: the page, its modules, and the vendored runtime files its import map,
#: stylesheet and loaders name. Development files (package.json, jsconfig.json, tests, the rest of
#: node_modules) are not served.
CLIENT_FILES: tuple[str, ...] = (
    "index.html",
    "src/",
    "node_modules/three/build/",
    "node_modules/three/examples/jsm/",
    "node_modules/iwer/build/",
    "node_modules/@webxr-input-profiles/assets/dist/profiles/",
    "node_modules/@fontsource/inter/files/",
)


def _existing_file(base: Path, relative: str) -> Path | None:
    try:
        target = (base / relative).resolve()
        return target if target.is_relative_to(base) and target.is_file() else None
    except (ValueError, OSError):
        return None


def static_handler(
    root: Path, allowed: tuple[str, ...] | None = None
) -> Callable[[web.Request], Awaitable[web.StreamResponse]]:
    """Serve files below ``root`` (only those under the ``allowed`` prefixes, when given) with the content types
    above; nothing outside it, no listings. A path that cannot name a file (a NUL byte, a name too long for
    the file system) is a 404 like any missing file, never a 500."""
    base = root.resolve()

    async def handler(request: web.Request) -> web.StreamResponse:
        relative = request.match_info.get("path", "") or "index.html"
        if allowed is not None and not relative.startswith(allowed):
            raise web.HTTPNotFound()
        # Off the loop: resolving a path and its stat wait for the disk, which on a busy machine held the loop 0.5 s.
        target = await asyncio.to_thread(_existing_file, base, relative)
        if target is None:
            raise web.HTTPNotFound()
        content_type = CONTENT_TYPES.get(target.suffix.lower(), "application/octet-stream")
        return web.FileResponse(target, headers={"Content-Type": content_type})

    return handler


async def websocket_handler(request: web.Request) -> web.StreamResponse:
    relay = request.app[RELAY_KEY]
    access = request.app[ACCESS_KEY]
    address = request.remote or "unknown"
    if request.headers.get("Upgrade", "").lower() != "websocket":
        # An <img src=".../ws?token=guess"> or a plain GET is not a handshake: its token is never looked at.
        return web.Response(status=400, text="not a WebSocket handshake\n")
    try:
        if "Origin" not in request.headers and "Sec-Fetch-Mode" in request.headers:
            # Browsers always send Origin with a WebSocket handshake; a browser request without one is forged.
            raise Refused(403, "a browser handshake without an Origin header")
        access.check_origin(request.headers.get("Origin"), f"{request.scheme}://{request.host}")
        session = request.app[SIGN_IN_KEY].session_of(request)
        if session is not None:
            role, delay, user = session.role, 0.0, session.user
        else:
            (role, delay), user = access.admit(request.query.get("token"), address, time.monotonic()), None
    except Refused as exc:
        # Never log the query string: it carries the token.
        logger.warning("refused a connection from %s: %s", address, exc.reason)
        await asyncio.sleep(exc.delay)  # a guesser waits; nobody else does
        return web.Response(status=exc.status, text=exc.reason + "\n")
    if delay > 0:
        await asyncio.sleep(delay)
    # compress=False: per-message deflate would compress per client and defeat "encode once".
    ws = web.WebSocketResponse(
        compress=False, max_msg_size=MAX_FRAME_BYTES, heartbeat=20.0, writer_limit=WEBSOCKET_WRITER_LIMIT
    )
    bound_backlog(request.transport)
    await ws.prepare(request)
    request.app[GUARD_KEY].admitted(request.protocol)
    request.app[SOCKETS_KEY].add(ws)
    watch = request.app[SIGN_IN_KEY].watch
    # Only the users file's accounts change under a running relay: the provider's people are the provider's to end.
    local = session is not None and session.provider == "local"
    forget_page = (
        watch.attach(user, lambda code, why: ws.close(code=code, message=why)) if watch and user and local else None
    )
    batch = request.query.get("batch") == "1"  # the client reads JSON arrays of state messages (relay.station.hub)
    client: Client = relay.connect(AiohttpTransport(ws), role=role, address=address, batch=batch, user=user)
    # Each frame is dated by the read that brought it, a read after a stall of the loop to the stall's start: a
    # motion command that waited longer than the deadman's timeout, in a frozen relay's socket buffer or before the
    # relay got to it, is dropped (relay.session.commands), stamped by its client or not (relay.net.loop_lag).
    # A stall the beat sees before the reads: what the socket holds then waited through it.
    dates = ArrivalDates(relay.clock())
    transport = request.transport
    date_reads(transport, lambda: dates.read(relay.loop_lag.arrival(relay.clock())))
    forget_stalls = relay.loop_lag.on_stall(
        lambda start: dates.read(start) if transport is not None and unread_bytes(transport) else None
    )
    try:
        async for msg in ws:
            if msg.type == WSMsgType.TEXT:
                await relay.handle_text(client, msg.data, relay.clock(), dates.frame())
            elif msg.type == WSMsgType.BINARY:
                relay.handle_binary(client)
            elif msg.type == WSMsgType.ERROR:
                logger.info("client %s: connection error %s", client.client_id, ws.exception())
    except asyncio.CancelledError:
        raise
    except Exception:
        logger.exception("handler for client %s crashed; closing its connection", client.client_id)
        await ws.close(code=WSCloseCode.INTERNAL_ERROR, message=b"internal error")
    finally:
        forget_stalls()
        if forget_page is not None:
            forget_page()
        request.app[SOCKETS_KEY].discard(ws)
        await relay.disconnect(client)
    return ws


async def check_token(request: web.Request) -> web.Response:
    """POST /auth with the token as the body: what a handshake with it would get (200 and the role, or the
    refusal), under the same Origin check and the same slowing of wrong tokens. A browser cannot see why a
    WebSocket handshake failed; the page asks here, so that a tab with a stale token stops retrying and says
    what to do instead of knocking every few seconds."""
    access = request.app[ACCESS_KEY]
    address = request.remote or "unknown"
    body = await request.content.read(1025)
    try:
        if len(body) > 1024:
            raise Refused(400, "a token is shorter than that")
        access.check_origin(request.headers.get("Origin"), f"{request.scheme}://{request.host}")
        token = body.decode("utf-8", errors="replace").strip() or None
        session = request.app[SIGN_IN_KEY].session_of(request)
        role, delay = (session.role, 0.0) if session is not None else access.admit(token, address, time.monotonic())
    except Refused as exc:
        await asyncio.sleep(exc.delay)
        return web.Response(status=exc.status, text=exc.reason + "\n")
    if delay > 0:
        await asyncio.sleep(delay)
    return web.json_response({"role": role})


async def generated_scene(request: web.Request) -> web.Response:
    """A twin the relay built (from a live map); kept in memory, replaced when the map changes."""
    glb = request.app[RELAY_KEY].generated.get(request.match_info["name"])
    if glb is None:
        raise web.HTTPNotFound(text="no such generated scene (the map may have changed since)")
    return web.Response(body=glb, content_type="model/gltf-binary")


async def healthz(request: web.Request) -> web.Response:
    relay = request.app[RELAY_KEY]
    now = time.monotonic()
    failure = relay.backend.failure
    audit_failure = relay.audit.failure
    store_failure = relay.inspection.store_failure
    return web.json_response(
        {
            "status": "degraded" if failure or audit_failure or store_failure else "ok",
            "version": __version__,
            "backend": relay.backend.name,
            "backend_error": failure,
            "audit_error": audit_failure,
            "inspection_error": store_failure,
            "webhooks": relay.inspection.webhooks.health(),
            "robots": {r: relay.fleet.online(r, now) for r in relay.config.names},
            "robots_online": relay.fleet.robots_online(now),
            "clients": relay.clients,
            "uptime": round(relay.uptime(), 3),
            # How late the loop's 10 ms beat ran (relay.net.loop_lag): the delay any estop could have met just now.
            "loop_lag": relay.loop_lag.stats.report(),
            **relay.backend.health(),  # e.g. the bag backend's playback position and duration
            **({"voxel_map": relay.fusion.health()} if relay.fusion is not None else {}),  # issue #33
        }
    )


async def metrics(request: web.Request) -> web.Response:
    relay = request.app[RELAY_KEY]
    c = relay.hub.counters
    guard = request.app[GUARD_KEY].counts
    lag = relay.loop_lag.stats
    now = time.monotonic()
    lines = [
        ("xr_relay_messages_in_total", "counter", "Frames received from clients", c.messages_in),
        ("xr_relay_messages_out_total", "counter", "Frames sent to clients", c.messages_out),
        ("xr_relay_bytes_out_total", "counter", "Bytes sent to clients", c.bytes_out),
        ("xr_relay_state_coalesced_total", "counter", "State values replaced before sending", c.state_coalesced),
        ("xr_relay_frames_dropped_total", "counter", "Camera frames dropped for slow clients", c.frames_dropped),
        ("xr_relay_clients_total", "counter", "Clients connected since start", c.clients_total),
        ("xr_relay_clients_dropped_total", "counter", "Clients disconnected for not reading", c.clients_dropped),
        ("xr_relay_clients", "gauge", "Clients connected now", relay.clients),
        ("xr_relay_robots_online", "gauge", "Robots with fresh data", relay.fleet.robots_online(now)),
        ("xr_relay_uptime_seconds", "gauge", "Seconds since start", round(relay.uptime(), 3)),
        ("xr_relay_connections", "gauge", "TCP connections now", guard["connections"]),
        (
            "xr_relay_connections_unadmitted",
            "gauge",
            "Connections not (yet) an admitted WebSocket",
            guard["unadmitted"],
        ),
        ("xr_relay_connections_timed_out_total", "counter", "Closed for not sending headers", guard["timed_out"]),
        ("xr_relay_connections_evicted_total", "counter", "Closed to make room (flood)", guard["evicted"]),
        (
            "xr_relay_accept_failures_total",
            "counter",
            "accept() failures (out of descriptors)",
            guard["accept_failures"],
        ),
        ("xr_relay_loop_lag_p99_seconds", "gauge", "Event loop lag, p99 of ~10 s", lag.p99()),
        ("xr_relay_loop_lag_worst_seconds", "gauge", "Event loop lag, worst of ~10 s", lag.worst()),
        ("xr_relay_loop_lag_worst_ever_seconds", "gauge", "Event loop lag, worst since start", lag.worst_ever),
    ]
    text = "".join(f"# HELP {n} {h}\n# TYPE {n} {t}\n{n} {v}\n" for n, t, h, v in lines)
    # Per robot and stage (relay.fleet.latency): the robot's stamp to the relay for poses and pictures, a teleop
    # command's age when handed to the backend; the median of the last few.
    latency = relay.latency.medians()
    text += (
        "# HELP xr_relay_latency_seconds How late each robot's data and commands are at the relay (median, recent)\n"
        "# TYPE xr_relay_latency_seconds gauge\n"
    ) + "".join(
        f'xr_relay_latency_seconds{{robot="{robot}",stage="{stage}"}} {round(value, 6)}\n'
        for (robot, stage), value in latency.items()
    )
    return web.Response(
        text=text, content_type="text/plain", charset="utf-8", headers={"X-Content-Type-Options": "nosniff"}
    )


async def _relay_context(app: web.Application) -> AsyncIterator[None]:
    relay = app[RELAY_KEY]
    await relay.start()
    yield
    await relay.stop()


async def _close_sockets(app: web.Application) -> None:
    """on_shutdown: robots first, then every socket with GOING_AWAY."""
    relay = app[RELAY_KEY]
    await relay.stop_all_robots("relay shutting down")
    open_sockets = app[SOCKETS_KEY]
    sockets = list(open_sockets)
    await asyncio.gather(
        *(ws.close(code=WSCloseCode.GOING_AWAY, message=b"relay shutting down") for ws in sockets),
        return_exceptions=True,
    )


@web.middleware
async def _guarded(
    request: web.Request, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]
) -> web.StreamResponse:
    """Every request: its connection's header deadline is met (relay.net.guard), and its Host is one of ours."""
    guard = request.app[GUARD_KEY]
    guard.request_started(request.protocol)
    try:
        try:
            request.app[ACCESS_KEY].check_host(request.headers.get("Host"))
        except Refused as exc:
            logger.warning("refused a request from %s: %s", request.remote, exc.reason)
            return web.Response(status=exc.status, text=exc.reason + "\n")
        return await handler(request)
    finally:
        guard.request_ended(request.protocol)


async def open_runner(app: web.Application) -> web.AppRunner:
    """The app's runner, set up, with its connections guarded (relay.net.guard): what ``serve`` and the tests use."""
    # access_log=None: the access log would write query strings, and /ws?token=... carries the token.
    # keepalive_timeout: an idle kept-alive connection is closed after this long (aiohttp's default is an hour).
    runner = web.AppRunner(app, shutdown_timeout=SHUTDOWN_TIMEOUT, access_log=None, keepalive_timeout=15.0)
    await runner.setup()
    assert runner.server is not None
    app[GUARD_KEY].attach(runner.server)
    return runner


async def _stop_guard(app: web.Application) -> None:
    app[GUARD_KEY].stop()


def own_host_names(options: Options) -> frozenset[str]:
    """Names the Host header may carry: localhost, this machine's names, ``--host``, ``--allow-host`` and the
    hosts of ``--allow-origin`` (IP addresses are always allowed; see ``Access.check_host``)."""
    hostname = socket.gethostname().lower()
    names = {"localhost", hostname, f"{hostname}.local", socket.getfqdn().lower(), options.host.lower()}
    names.update(h.lower().rstrip(".") for h in options.allowed_hosts)
    names.update(urlsplit(origin).hostname or "" for origin in options.allowed_origins)
    return frozenset(n for n in names if n)


def create_app(
    config: FleetConfig,
    options: Options | None = None,
    *,
    backend_factory: BackendFactory | None = None,
    clock: Callable[[], float] = time.monotonic,
    wall_clock: Callable[[], float] = time.time,
) -> web.Application:
    """``backend_factory``: a backend of the caller's (the benchmarks' synthetic fleet), else the one options name;
    ``clock``: the relay's (tests move a study's time by hand); ``wall_clock``: the time of day (tests move a
    schedule's time by hand)."""
    options = options or Options()
    app = web.Application(middlewares=[_guarded])
    app[RELAY_KEY] = Relay(config, options, backend_factory=backend_factory, clock=clock, wall_clock=wall_clock)
    book = UserBook(options.users) if options.users else None  # the command line names it only when it holds anyone
    accounts = book is not None
    app[ACCESS_KEY] = Access(
        options.token, options.allow_viewers, options.allowed_origins, allowed_hosts=own_host_names(options),
        accounts=accounts,
    )  # fmt: skip
    app[SIGN_IN_KEY] = SignIn(book if accounts else None, app[ACCESS_KEY], secure=bool(options.tls_cert))
    add_sign_in_routes(app, app[SIGN_IN_KEY])
    if accounts and options.oidc_issuer:
        oidc = OidcSettings(options.oidc_issuer, options.oidc_client_id, options.oidc_secret, options.oidc_role_claim)
        oidc_sign_in = OidcSignIn(oidc, app[SIGN_IN_KEY])
        add_oidc_routes(app, oidc_sign_in)
        app.cleanup_ctx.append(oidc_sign_in.closing)
        app[SIGN_IN_KEY].oidc_issuer = options.oidc_issuer
    app[GUARD_KEY] = ConnectionGuard(options.header_timeout, options.max_unadmitted)
    # Every response, errors included: the CSP the client and the report pass, nosniff, no referrer, no framing.
    headers = SecurityHeaders.for_pages(CLIENT_DIR, own_host=app[ACCESS_KEY].is_own_host)
    app.on_response_prepare.append(headers.on_response_prepare)
    app.on_cleanup.append(_stop_guard)
    app[SOCKETS_KEY] = set()
    app.cleanup_ctx.append(_relay_context)
    app.cleanup_ctx.append(app[SIGN_IN_KEY].watching)
    app.on_shutdown.append(_close_sockets)
    app.router.add_get("/ws", websocket_handler)
    app.router.add_post("/auth", check_token)
    app.router.add_get(r"/captures/{sha:[0-9a-f]{64}}.jpg", capture_image)
    app.router.add_get(r"/report/{name:[A-Za-z0-9_.-]{1,160}}", report)
    app.router.add_get("/webhooks/deliveries", webhook_deliveries)
    app.router.add_get("/healthz", healthz)
    app.router.add_get("/metrics", metrics)
    app.router.add_get("/scenes/generated/{name}", generated_scene)
    app.router.add_get("/scenes/{path:.*}", static_handler(SCENES_DIR))
    app.router.add_get("/{path:.*}", static_handler(CLIENT_DIR, CLIENT_FILES))
    return app


async def serve(config: FleetConfig, options: Options) -> None:
    """Run until SIGINT or SIGTERM, then shut down cleanly."""
    host, port, backend = options.host, options.port, options.backend
    app = create_app(config, options)
    runner = await open_runner(app)
    ssl_context = None
    if options.tls_cert and options.tls_key:
        ssl_context = server_context(Path(options.tls_cert), Path(options.tls_key))
    site = web.TCPSite(runner, host, port, ssl_context=ssl_context)
    try:
        await site.start()
        bound = runner.addresses[0] if runner.addresses else (host, port)
        shown_host = "127.0.0.1" if bound[0] in ("0.0.0.0", "::") else bound[0]
        shown = f"[{shown_host}]" if ":" in str(shown_host) else shown_host
        scheme = "https" if ssl_context else "http"
        url = f"{scheme}://{shown}:{bound[1]}/"
        logger.info("serving on %s", url)
        fragment = f"#token={options.token}" if options.token else ""
        sign_in = "sign in; " if options.users and not options.token else ""
        opened = f"xr-relay {__version__}: open {url}{fragment}  ({sign_in}backend: {backend}; Ctrl-C to stop)"
        print(opened, flush=True)  # noqa: T201
        if ssl_context and options.tls_cert:
            sha256 = fingerprint(Path(options.tls_cert))
            print(f"TLS certificate SHA-256 fingerprint: {sha256}", flush=True)  # noqa: T201
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        await stop.wait()
        logger.info("shutting down")
    finally:
        await runner.cleanup()
