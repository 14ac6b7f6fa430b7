"""The ``xr-relay`` command (also ``python -m relay``)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import secrets
import sqlite3
import sys
from pathlib import Path
from urllib.parse import urlsplit

from .. import __version__
from ..accounts.users import AccountError, UserBook
from ..backends import BACKENDS
from ..config import load_config
from ..errors import AuditLogUnavailable, BackendUnavailable, ConfigError, RecordingError
from ..inspection.kml import KmlError
from ..inspection.store import StoreError
from ..logs.redaction import redact_logs
from ..net.access import MIN_TOKEN_BITS, weak_token
from .options import BagOptions, Options, ReplayOptions, ZenohOptions

EXIT_USAGE = 2


def oidc_refusal(issuer: str | None, accounts: bool, secret: str) -> str | None:
    """Why ``--oidc-issuer`` cannot be used as given, or None."""
    if issuer is None:
        return None
    parts = urlsplit(issuer)
    if not accounts:
        return "a sign-in provider needs accounts (it is not used with --no-accounts)"
    if parts.scheme != "https" and not (parts.scheme == "http" and parts.hostname in ("127.0.0.1", "localhost", "::1")):
        return f"{issuer[:80]!r} is not an https:// URL (tokens would cross the network in clear)"
    if not secret:
        return "the client secret is missing: set $XR_RELAY_OIDC_SECRET (never an argument: others can read those)"
    return None


def build_parser(*, replay: bool = False) -> argparse.ArgumentParser:
    """The relay's options; ``replay``: those of ``xr-relay replay FILE`` (a recorded session instead of a backend)."""
    parser = argparse.ArgumentParser(
        prog="xr-relay replay" if replay else "xr-relay",
        description=(
            "Serves a session recorded with --record-session to browsers and headsets, played back on the page's "
            "timeline (pause, seek, speed); nothing reaches a robot (docs/study.md)."
            if replay
            else "WebXR operator station relay: bridges a ROS 2 robot fleet (or the built-in simulated fleet) to "
            "browsers and headsets over one WebSocket, and serves the WebXR client on the same port."
        ),
        epilog="Open the printed URL in a browser. `xr-relay record --out DIR` records the fleet's topics from a "
        "live ROS 2 graph (see `xr-relay record --help`); `xr-relay watchdog` stops robots when the relay cannot "
        "(see `xr-relay watchdog --help`). Protocol: docs/protocol.md; configuration: "
        "docs/configuration.md; security: docs/security.md.",
    )
    if replay:
        parser.add_argument("session", metavar="FILE", help="the session recording (an MCAP of --record-session)")
        parser.set_defaults(backend="replay", bag=[], zenoh_connect=[], zenoh_mode=None, zenoh_config=None)
        parser.set_defaults(relay_id=None)
    else:
        parser.set_defaults(session=None)
    parser.add_argument(
        "--config",
        type=Path,
        default=Path("robots.yaml"),
        help="fleet configuration file (default: ./robots.yaml)",
    )
    if not replay:
        _add_backend_option(parser)
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine only; use 0.0.0.0 to serve the LAN)",
    )
    parser.add_argument(
        "--port", type=int, default=None, help="TCP port (default 8080, or 8443 with TLS; 0 picks a free one)"
    )
    parser.add_argument(
        "--log-level",
        default="info",
        choices=("debug", "info", "warning", "error"),
        help="logging verbosity (default info)",
    )
    parser.add_argument(
        "--audit-log",
        default="xr-relay-audit.jsonl",
        metavar="PATH",
        help="append every command accepted or refused to this JSON-lines file, rotated at 10 MB "
        "(default ./xr-relay-audit.jsonl; '' turns it off)",
    )
    parser.add_argument(
        "--record-session",
        metavar="FILE",
        help="record the session to this MCAP file (never overwritten): every message the relay sends and every "
        "frame it is sent, with the client's id (docs/study.md)",
    )
    parser.add_argument(
        "--study",
        metavar="FILE",
        help="run the user study of this file (docs/study.md): participants join and do its tasks from their page; "
        "xr-relay study check FILE checks it first",
    )
    parser.add_argument(
        "--study-runs",
        default="xr-relay-studies",
        metavar="DIR",
        help="where the study's runs are kept, one JSON file per participant (default ./xr-relay-studies; "
        "xr-relay study export --runs reads them)",
    )
    inspection = parser.add_argument_group("inspection (missions, captures, findings)")
    inspection.add_argument(
        "--database",
        default="xr-relay-inspection.sqlite",
        metavar="FILE_OR_URL",
        help="where missions, captures and findings are kept: a SQLite file (default ./xr-relay-inspection.sqlite, "
        "images in ./xr-relay-inspection-images) or a postgresql:// URL (better without its password: libpq reads "
        "$PGPASSWORD and ~/.pgpass; a password in the URL is never logged)",
    )
    inspection.add_argument(
        "--images",
        metavar="DIR",
        help="capture images (default: beside a SQLite file; for PostgreSQL ~/.local/share/xr-relay/images)",
    )
    inspection.add_argument("--targets", metavar="FILE", help="a targets file besides the facility's own targets")
    _add_access_options(parser.add_argument_group("access (docs/security.md)"))
    _add_tls_options(parser.add_argument_group("TLS, for headsets on the LAN (WebXR needs https except on localhost)"))
    if replay:
        _add_playback_options(parser.add_argument_group("playback"), "session")
    else:
        _add_bag_options(parser.add_argument_group("recordings (--backend bag)"))
        _add_zenoh_options(parser.add_argument_group("Zenoh (--backend zenoh; docs/zenoh.md)"))
    parser.add_argument("--version", action="version", version=f"xr-relay {__version__}")
    return parser


def _add_backend_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--backend",
        choices=BACKENDS,
        default="sim",
        help="where robots come from: sim = built-in simulated fleet (default, no ROS needed), "
        "ros = a live ROS 2 graph through rclpy, bag = recorded topics, zenoh = ROS 2 over a Zenoh network "
        "(rmw_zenoh or zenoh-bridge-ros2dds; no ROS install needed); a recorded session: xr-relay replay FILE",
    )


def _add_access_options(access: argparse._ArgumentGroup) -> None:
    access.add_argument(
        "--token",
        help="the operator token (default: $XR_RELAY_TOKEN, else a new random one each start), of at least "
        f"{MIN_TOKEN_BITS} bits of entropy (e.g. python3 -c 'import secrets; print(secrets.token_urlsafe(32))'); "
        "the relay prints its URL as http://HOST:PORT/#token=TOKEN, and clients pass it as /ws?token=TOKEN",
    )
    access.add_argument(
        "--users",
        default="xr-relay-users.sqlite",
        metavar="FILE",
        help="the accounts file (default ./xr-relay-users.sqlite; xr-relay users manages it): people sign in, and "
        "the operator token is off unless --token or $XR_RELAY_TOKEN gives one; the first start makes the account "
        "'admin' and prints its password once",
    )
    access.add_argument(
        "--no-accounts",
        action="store_true",
        help="a lab bench: no accounts (no users file read or made), the operator token alone, as before accounts",
    )
    access.add_argument(
        "--oidc-issuer",
        metavar="URL",
        help="the site's OpenID Connect provider (its issuer URL): people may also sign in with it (the relay's "
        "redirect URI is https://HOST:PORT/oidc/callback); the client secret comes from $XR_RELAY_OIDC_SECRET",
    )
    access.add_argument("--oidc-client-id", default="xr-relay", help="this relay's client id at the provider")
    access.add_argument(
        "--oidc-role-claim",
        default="roles",
        help="the ID token claim naming each person's station role (admin, operator, inspector or viewer)",
    )
    access.add_argument(
        "--allow-weak-token",
        action="store_true",
        help=f"accept a --token (or $XR_RELAY_TOKEN) of fewer than {MIN_TOKEN_BITS} bits of entropy, for a closed "
        "test network only; the relay says so at start-up",
    )
    access.add_argument(
        "--allow-viewers",
        action="store_true",
        help="let clients without a valid token connect as viewers: they see everything, command nothing",
    )
    access.add_argument(
        "--allow-origin",
        action="append",
        default=[],
        metavar="ORIGIN",
        help="a web origin (scheme://host:port) allowed to open /ws besides the relay's own; repeatable",
    )
    access.add_argument(
        "--allow-host",
        action="append",
        default=[],
        metavar="NAME",
        help="a host name the relay is reached by, besides IP addresses, localhost and this machine's names "
        "(requests naming any other Host are refused: DNS rebinding); repeatable",
    )
    access.add_argument(
        "--max-message-rate",
        type=float,
        default=60.0,
        metavar="PER_SECOND",
        help="messages a client may send per second, bursts of twice that allowed (default 60; estop is "
        "never limited); faster ones get error rate_limited",
    )
    access.add_argument(
        "--lease-timeout",
        type=float,
        default=30.0,
        metavar="SECONDS",
        help="release an idle robot's control lease after this long without commands (default 30)",
    )


def _add_tls_options(tls: argparse._ArgumentGroup) -> None:
    tls.add_argument(
        "--tls",
        choices=("off", "auto"),
        default="off",
        help="auto: create (once) and use a self-signed certificate for this machine's names and addresses, "
        "serve https/wss and print the certificate's fingerprint",
    )
    tls.add_argument("--tls-cert", metavar="PEM", help="serve https/wss with this certificate (chain) ...")
    tls.add_argument("--tls-key", metavar="PEM", help="... and this private key")
    tls.add_argument(
        "--tls-dir",
        type=Path,
        default=Path.home() / ".local" / "share" / "xr-relay" / "tls",
        help="where --tls auto keeps its certificate (default ~/.local/share/xr-relay/tls)",
    )


def _add_bag_options(bag: argparse._ArgumentGroup) -> None:
    bag.add_argument(
        "--bag",
        action="append",
        default=[],
        metavar="[ROBOT=]PATH",
        help="a rosbag2 recording (sqlite3 or MCAP; a bag directory or file) to replay; ROBOT= binds it to a "
        "robot of the config, otherwise a bag of un-namespaced topics plays as the first robot not yet bound. "
        "Repeat for several robots",
    )
    _add_playback_options(bag, "recordings")


def _add_playback_options(group: argparse._ArgumentGroup, what: str) -> None:
    group.add_argument("--rate", type=float, default=1.0, help="replay speed factor (default 1.0)")
    group.add_argument("--loop", action="store_true", help=f"start over at the end of the {what}")
    group.add_argument("--start", type=float, default=0.0, metavar="SECONDS", help=f"start this far into the {what}")


def _add_zenoh_options(zenoh: argparse._ArgumentGroup) -> None:
    zenoh.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="a Zenoh router (or peer) to connect to, e.g. tcp/10.0.0.5:7447; repeatable (default: robots.yaml's "
        "zenoh.connect, else the local router tcp/127.0.0.1:7447)",
    )
    zenoh.add_argument("--zenoh-mode", choices=("client", "peer"), help="Zenoh session mode (default client)")
    zenoh.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="a Zenoh JSON5 configuration file (TLS certificates, user/password, ...), passed to Zenoh as is",
    )
    zenoh.add_argument(
        "--relay-id",
        metavar="NAME",
        help="this relay's name among the relays of one fleet (default: its Zenoh session id)",
    )


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "record":
        # `xr-relay record --out DIR`: record the fleet's topics from a live ROS graph (relay/cli/record.py).
        from .record import main as record_main

        return record_main(argv[1:])
    if argv and argv[0] == "report":
        # `xr-relay report`: the inspection report and work orders as files (relay/inspection/report_cli.py).
        from ..inspection.report_cli import main as report_main

        return report_main(argv[1:])
    if argv and argv[0] == "schedule":
        # `xr-relay schedule add|list|remove`: schedules on the database directly (relay/inspection/schedule_cli.py).
        from ..inspection.schedule_cli import main as schedule_main

        return schedule_main(argv[1:])
    if argv and argv[0] == "study":
        # `xr-relay study check|export`: a study file checked, its runs exported (relay/study/cli.py).
        from ..study.cli import main as study_main

        return study_main(argv[1:])
    if argv and argv[0] == "users":
        # `xr-relay users add|passwd|role|remove|list`: the accounts people sign in with (relay/accounts/cli.py).
        from ..accounts.cli import main as users_main

        return users_main(argv[1:])
    if argv and argv[0] == "watchdog":
        # `xr-relay watchdog`: the robot-side stop (relay/watchdog/node.py), run on or next to the robots.
        from ..watchdog.node import main as watchdog_main

        return watchdog_main(argv[1:])
    if argv and argv[0] == "replay":
        # `xr-relay replay FILE`: a session recorded with --record-session, served for review (relay/replay/).
        args = build_parser(replay=True).parse_args(argv[1:])
    else:
        args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=getattr(logging, args.log_level.upper()),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    redact_logs()  # a database URL's password or a token in a log line is written as *** (relay.logs.redaction)
    log = logging.getLogger("relay")
    token, source = (args.token, "--token") if args.token else (os.environ.get("XR_RELAY_TOKEN"), "$XR_RELAY_TOKEN")
    why = weak_token(token) if token else None
    if why is not None and not args.allow_weak_token:
        log.error(
            "%s: the operator token has %s. Give one of at least %d bits (python3 -c 'import secrets; "
            "print(secrets.token_urlsafe(32))'), or none for a new random one each start; --allow-weak-token "
            "accepts it anyway (a closed test network only)",
            source, why, MIN_TOKEN_BITS,
        )  # fmt: skip
        return EXIT_USAGE
    if why is not None:
        log.warning(
            "WEAK OPERATOR TOKEN, accepted because of --allow-weak-token: %s has %s. Anyone who can reach this "
            "relay may guess it and command the robots: use it on a closed test network only",
            source, why,
        )  # fmt: skip
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        log.error("%s", exc)
        return EXIT_USAGE
    if args.study:
        from ..study.study_file import load_study

        try:
            load_study(args.study)  # read again at start (relay/study/service.py), with the fleet's robots checked
        except ConfigError as exc:
            log.error("--study: %s", exc)
            return EXIT_USAGE
    # After the configuration: a start that fails on it makes no account.
    accounts = bool(args.users) and not args.no_accounts
    if accounts:
        try:
            made = UserBook(args.users).first_admin()
        except (AccountError, sqlite3.Error) as exc:
            log.error("--users %s: %s", args.users, exc)
            return EXIT_USAGE
        if made is not None:  # printed once, on stdout: never a log line (the password would stay in the logs)
            print(  # noqa: T201
                f"xr-relay {__version__}: first start: made the account {made[0].name!r} (admin) in {args.users}, "
                f"password {made[1]} - shown only now (xr-relay users passwd {made[0].name} changes it; "
                "xr-relay users add NAME --role operator adds people)",
                flush=True,
            )
        log.info("accounts: %s; people sign in%s", args.users, " (and the operator token works)" if token else "")
    why_not = oidc_refusal(args.oidc_issuer, accounts, os.environ.get("XR_RELAY_OIDC_SECRET", ""))
    if why_not is not None:
        log.error("--oidc-issuer: %s", why_not)
        return EXIT_USAGE
    from ..net.server import serve

    try:
        if bool(args.tls_cert) != bool(args.tls_key):
            log.error("--tls-cert and --tls-key go together")
            return EXIT_USAGE
        cert, key = args.tls_cert, args.tls_key
        if args.tls == "auto" and not cert:
            from ..net.tls import ensure_certificate

            extra = (args.host,) if args.host not in ("0.0.0.0", "::", "127.0.0.1") else ()
            cert_path, key_path = ensure_certificate(args.tls_dir, extra)
            cert, key = str(cert_path), str(key_path)
        port = args.port if args.port is not None else (8443 if cert else 8080)
        options = Options(
            backend=args.backend,
            host=args.host,
            port=port,
            token=token or (None if accounts else secrets.token_urlsafe(24)),
            users=args.users if accounts else None,
            oidc_issuer=args.oidc_issuer if accounts else None,
            oidc_client_id=args.oidc_client_id,
            oidc_secret=os.environ.get("XR_RELAY_OIDC_SECRET", ""),
            oidc_role_claim=args.oidc_role_claim,
            allow_viewers=args.allow_viewers,
            allowed_origins=tuple(o.rstrip("/") for o in args.allow_origin),
            allowed_hosts=tuple(args.allow_host),
            tls_cert=cert,
            tls_key=key,
            max_message_rate=args.max_message_rate,
            lease_timeout=args.lease_timeout,
            bag=BagOptions(bags=tuple(args.bag), rate=args.rate, loop=args.loop, start=args.start),
            replay=ReplayOptions(session=args.session, rate=args.rate, loop=args.loop, start=args.start),
            zenoh=ZenohOptions(
                connect=tuple(args.zenoh_connect),
                mode=args.zenoh_mode,
                config=args.zenoh_config,
                relay_id=args.relay_id,
            ),
            audit_log=args.audit_log or None,
            record_session=args.record_session,
            study=args.study,
            study_runs=args.study_runs,
            database=args.database,
            images=args.images,
            targets=args.targets,
        )
        asyncio.run(serve(config, options))
    except (BackendUnavailable, AuditLogUnavailable, StoreError, KmlError, ConfigError, RecordingError) as exc:
        log.error("%s", exc)
        return EXIT_USAGE
    except OSError as exc:
        log.error("cannot listen on %s:%s: %s", args.host, args.port, exc.strerror or exc)
        return EXIT_USAGE
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
