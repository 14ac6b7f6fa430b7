"""Security headers on every HTTP response: a Content-Security-Policy, ``nosniff``, ``no-referrer`` and no framing.

The relay serves one page and its modules, scenes, capture images and reports, all from its own origin; the policy
allows that and nothing else, so that markup that got into a page (a finding's note, a target's name) cannot run
script, load from or send to another site, or have the page framed by one (clickjacking of the E-STOP button).
What the pages need, and why each source is there:

- ``script-src 'self'`` and the hash of each inline ``<script>`` of ``xr_client/index.html`` (its import map),
  computed when the app is built; ``'wasm-unsafe-eval'``: three's meshopt decoder compiles WebAssembly when it is
  imported, and the Draco and Basis (KTX2) decoders do in their workers (it allows WebAssembly, not ``eval``);
- ``worker-src 'self' blob:``: the socket worker is a module of ours; three's decoders start workers from blobs;
- ``connect-src``: the WebSocket to this origin (named as ``ws://`` or ``wss://`` with the request's Host, which
  ``'self'`` covers in CSP 3 but not in every browser), and ``blob:``/``data:`` for glTF buffers and textures;
- ``img-src 'self' data: blob:``: capture images, the report's embedded images, glTF textures, the empty favicon;
- ``style-src 'self'`` and the hash of the report's own stylesheet (relay/inspection/report.css, embedded so the
  report stays one file); the pages set no ``style`` attribute (colours are set through CSSOM, which CSP allows);
- ``frame-ancestors 'none'`` (with ``X-Frame-Options: DENY`` for older browsers), ``base-uri 'none'``,
  ``object-src 'none'``, ``form-action 'self'``.

Tested with a real page load in Chromium that reports no violation (tests/e2e/test_security_headers.py).
"""

from __future__ import annotations

import base64
import hashlib
import re
from collections.abc import Callable
from pathlib import Path

from aiohttp import web

#: Headers every response gets (a handler's own value, if it set one, is kept).
FIXED_HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
}
REPORT_STYLESHEET = Path(__file__).resolve().parent.parent / "inspection" / "report.css"
_INLINE_SCRIPT = re.compile(r"<script(?![^>]*\bsrc=)[^>]*>(.*?)</script>", re.DOTALL | re.IGNORECASE)
#: A Host header the policy may name: a DNS name or an IP literal, with a port (anything else gets 'self' only).
_HOST = re.compile(r"(?:[A-Za-z0-9-]+(?:\.[A-Za-z0-9-]+)*\.?|\[[0-9A-Fa-f:.]+\])(?::\d{1,5})?")


def source_hash(text: str) -> str:
    """The CSP source expression allowing an inline script or stylesheet of exactly ``text``."""
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


def inline_script_hashes(html: str) -> tuple[str, ...]:
    """The hashes of a page's inline scripts (its import map), in order."""
    return tuple(source_hash(body) for body in _INLINE_SCRIPT.findall(html))


class SecurityHeaders:
    """The headers of every response of one app; ``scripts`` and ``styles`` are the inline ones allowed by hash."""

    def __init__(
        self,
        scripts: tuple[str, ...] = (),
        styles: tuple[str, ...] = (),
        own_host: Callable[[str], bool] = lambda host: True,
    ) -> None:
        self._own_host = own_host  # a Host the relay answers to (relay.net.access.Access.check_host), else not named
        self._before_connect = "; ".join(
            (
                "default-src 'self'",
                " ".join(("script-src 'self' 'wasm-unsafe-eval'", *scripts)),
                " ".join(("style-src 'self'", *styles)),
                "img-src 'self' data: blob:",
                "media-src 'self' blob:",
                "font-src 'self'",
                "worker-src 'self' blob:",
                "object-src 'none'",
                "base-uri 'none'",
                "form-action 'self'",
                "frame-ancestors 'none'",
            )
        )

    @classmethod
    def for_pages(cls, client_dir: Path, own_host: Callable[[str], bool]) -> SecurityHeaders:
        """The policy for the client in ``client_dir`` and the inspection report (read once, at start-up)."""
        index = client_dir / "index.html"
        scripts = inline_script_hashes(index.read_text(encoding="utf-8")) if index.is_file() else ()
        return cls(scripts, (source_hash(REPORT_STYLESHEET.read_text(encoding="utf-8")),), own_host)

    def policy(self, host: str | None, secure: bool) -> str:
        """The Content-Security-Policy of a response to a request with this Host, over TLS or not."""
        connect = "connect-src 'self' blob: data:"
        if host and _HOST.fullmatch(host) and self._own_host(host):
            connect += f" {'wss' if secure else 'ws'}://{host}"
        return f"{self._before_connect}; {connect}"

    async def on_response_prepare(self, request: web.Request, response: web.StreamResponse) -> None:
        """aiohttp's ``on_response_prepare`` signal: every response, the handlers' and the errors' alike."""
        headers = response.headers
        for name, value in FIXED_HEADERS.items():
            headers.setdefault(name, value)
        headers.setdefault("Content-Security-Policy", self.policy(request.headers.get("Host"), request.secure))
