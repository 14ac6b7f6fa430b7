"""Run-time options of one relay process (from the command line), as opposed to the fleet (robots.yaml)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class BagOptions:
    """``--backend bag``: which recordings to replay and how."""

    #: ``PATH`` or ``ROBOT=PATH``, as given on the command line, in order.
    bags: tuple[str, ...] = ()
    rate: float = 1.0
    loop: bool = False
    start: float = 0.0  # seconds from the recordings' start


@dataclass(frozen=True)
class ReplayOptions:
    """``xr-relay replay FILE``: a recorded station session (relay/replay/) and how it is played."""

    session: str | None = None
    rate: float = 1.0
    loop: bool = False
    start: float = 0.0  # seconds from the session's start


@dataclass(frozen=True)
class ZenohOptions:
    """``--backend zenoh``: command-line settings that override robots.yaml's ``zenoh`` section."""

    connect: tuple[str, ...] = ()
    mode: str | None = None
    config: str | None = None
    relay_id: str | None = None


@dataclass(frozen=True)
class Options:
    backend: str = "sim"
    host: str = "127.0.0.1"
    port: int = 8080
    bag: BagOptions = field(default_factory=BagOptions)
    zenoh: ZenohOptions = field(default_factory=ZenohOptions)
    replay: ReplayOptions = field(default_factory=ReplayOptions)
    #: JSON-lines file of every command accepted or refused (relay/station/audit.py); None: no audit log.
    audit_log: str | None = None
    #: An MCAP file the session is recorded to (relay/replay/recorder.py); None: not recorded.
    record_session: str | None = None
    #: A study file the relay runs (relay/study/service.py, docs/study.md); None: no study.
    study: str | None = None
    #: Where a study's runs are kept (a folder per study, a JSON file per participant).
    study_runs: str = "xr-relay-studies"
    #: Seconds without commands after which an idle robot's lease is released.
    lease_timeout: float = 30.0
    #: The operator token; None: no token needed (library use and tests; the command line always sets one).
    token: str | None = None
    allow_viewers: bool = False
    #: The accounts file (relay/accounts/users.py): people sign in. None: no accounts (the command line gives it only
    #: when it holds anyone, read once at start-up, before the event loop).
    users: str | None = None
    #: The site's OpenID Connect provider (an issuer URL), its client id and secret for this relay, and the ID token
    #: claim naming each person's role (relay/net/oidc.py); None: password and pairing sign-in only.
    oidc_issuer: str | None = None
    oidc_client_id: str = ""
    oidc_secret: str = ""
    oidc_role_claim: str = "roles"
    #: Origins allowed besides the relay's own, e.g. ("https://ops.example.org",).
    allowed_origins: tuple[str, ...] = ()
    #: Host names (of the Host header) allowed besides IP addresses, localhost and this machine's names.
    allowed_hosts: tuple[str, ...] = ()
    #: Seconds a connection has to send its request's headers (relay.net.guard).
    header_timeout: float = 10.0
    #: Connections that are not an admitted WebSocket kept at once; one more closes the oldest (relay.net.guard).
    max_unadmitted: int = 256
    #: Certificate and key (PEM) to serve https/wss; None: plain http/ws.
    tls_cert: str | None = None
    tls_key: str | None = None
    #: The inspection database: a SQLite file or a postgresql:// URL; None: a temporary one for this run.
    database: str | None = None
    #: Where capture images are kept (default: relay.inspection.store.default_images, never the working directory).
    images: str | None = None
    #: A targets file (relay/inspection/targets.py) besides the facility's own.
    targets: str | None = None
    #: Mission files a client may start by name.
    missions_dir: Path = field(default_factory=lambda: Path(__file__).resolve().parent.parent.parent / "missions")
    #: Messages per second a client may send (sustained; bursts of twice that pass); estop is never limited.
    max_message_rate: float = 60.0
