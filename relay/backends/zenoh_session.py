"""Opening the ``zenoh`` backend's session: robots.yaml's ``zenoh`` section, the command line on top, and a Zenoh
configuration file passed through untouched (TLS, user/password and anything else Zenoh can do is Zenoh's, not
re-implemented here). Imports zenoh lazily; its absence, a bad file or an unreachable router are one clear line.
"""

from __future__ import annotations

import importlib
import json
import os
import re
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from ..cli.options import ZenohOptions
from ..config import Zenoh
from ..errors import BackendUnavailable
from .zenoh_keys import KeyStyle

INSTALL_HINT = "the zenoh backend needs the Zenoh Python API: `pip install '.[zenoh]'` (as `make setup` does)"
#: Where rmw_zenoh's router listens by default (``ros2 run rmw_zenoh_cpp rmw_zenohd``).
DEFAULT_ROUTER = "tcp/127.0.0.1:7447"
#: How long opening a client session waits for its router before the relay refuses to start (ms). Zenoh's own
#: default for a client is to wait for ever: a relay pointed at a wrong address would hang with no message.
CONNECT_TIMEOUT_MS = 3000


@dataclass(frozen=True)
class ZenohSettings:
    connect: tuple[str, ...]
    mode: str
    config_file: str | None
    keys: KeyStyle
    domain: int
    fleet_key: str
    relay_id: str | None
    #: Seconds a lease held through another relay lasts after that relay's last heartbeat.
    peer_lease_timeout: float = 10.0
    #: Endpoints to listen on besides connecting (tests, tools/fake_fleet.py --zenoh); none for a relay.
    listen: tuple[str, ...] = ()

    def where(self) -> str:
        return ", ".join(self.connect) or "(no endpoint)"


def settings(config: Zenoh, options: ZenohOptions) -> ZenohSettings:
    """robots.yaml's ``zenoh`` section with the command line's ``--zenoh-*`` on top."""
    domain = config.domain_id
    if domain is None:
        raw = os.environ.get("ROS_DOMAIN_ID", "").strip()
        domain = int(raw) if raw.isdigit() else 0
    keys: KeyStyle = "bridge" if config.keys == "bridge" else "rmw_zenoh"
    return ZenohSettings(
        connect=options.connect or config.connect or (DEFAULT_ROUTER,),
        mode=options.mode or config.mode,
        config_file=options.config or config.config,
        keys=keys,
        domain=domain,
        fleet_key=config.fleet_key,
        relay_id=options.relay_id or config.relay_id,
        peer_lease_timeout=config.peer_lease_timeout,
    )


_SOURCE = re.compile(r" at /\S+\.rs:\d+\.?")


def _why(exc: Exception) -> str:
    """A Zenoh error without the Rust source locations it carries (``... at <cargo registry>/.../config.rs:86.``)."""
    return _SOURCE.sub("", str(exc)).strip()


def load_zenoh() -> ModuleType:
    try:
        return importlib.import_module("zenoh")
    except ImportError as exc:
        raise BackendUnavailable(f"{INSTALL_HINT} ({exc})") from None


def session_config(zenoh: ModuleType, s: ZenohSettings) -> Any:
    """A zenoh.Config: the file's (if any), then mode, endpoints, and no multicast scouting (a relay talks to the
    routers it is given, never to whatever answers on the LAN)."""
    if s.config_file is not None:
        try:
            config = zenoh.Config.from_file(s.config_file)
        except Exception as exc:  # zenoh raises ZError for a missing file and for bad JSON5 alike
            why = _why(exc)
            raise BackendUnavailable(f"the Zenoh configuration file {s.config_file} cannot be used: {why}") from None
    else:
        config = zenoh.Config()
    try:
        config.insert_json5("mode", json.dumps(s.mode))
        config.insert_json5("connect/endpoints", json.dumps(list(s.connect)))
        config.insert_json5("listen/endpoints", json.dumps(list(s.listen)))
        config.insert_json5("scouting/multicast/enabled", "false")
        if s.mode == "client":
            config.insert_json5("connect/timeout_ms", str(CONNECT_TIMEOUT_MS))
            config.insert_json5("connect/exit_on_failure", "true")
    except Exception as exc:
        raise BackendUnavailable(f"zenoh: bad endpoint or mode ({s.where()}, {s.mode}): {_why(exc)}") from None
    return config


def open_session(s: ZenohSettings) -> Any:
    """Blocking (a worker thread): the open session, or BackendUnavailable naming the endpoints."""
    zenoh = load_zenoh()
    config = session_config(zenoh, s)
    try:
        return zenoh.open(config)
    except Exception as exc:
        raise BackendUnavailable(
            f"zenoh: cannot reach the router at {s.where()} ({s.mode} mode) within "
            f"{CONNECT_TIMEOUT_MS / 1000:.0f} s ({_why(exc)}); is a Zenoh router (zenohd, rmw_zenohd or "
            "zenoh-bridge-ros2dds) running there, and is the address right?"
        ) from None


def connected(session: Any) -> bool:
    """Whether the session has a router or a peer to talk to right now."""
    info = session.info
    return bool(info.routers_zid()) or bool(info.peers_zid())
