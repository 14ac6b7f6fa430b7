"""The ``xr-relay`` command (also ``python -m relay``)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import sys
from pathlib import Path

from . import __version__
from .backends import BACKENDS
from .config import load_config
from .errors import BackendUnavailable, ConfigError
from .options import BagOptions, Options

EXIT_USAGE = 2


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="xr-relay",
        description=(
            "WebXR operator station relay: bridges a ROS 2 robot fleet (or the built-in simulated fleet) to "
            "browsers and headsets over one WebSocket, and serves the WebXR client on the same port."
        ),
        epilog="Open the printed URL in a browser. Protocol: docs/protocol.md; configuration: docs/configuration.md.",
    )
    parser.add_argument(
        "--config",
        type=Path,
        default=Path("robots.yaml"),
        help="fleet configuration file (default: ./robots.yaml)",
    )
    parser.add_argument(
        "--backend",
        choices=BACKENDS,
        default="sim",
        help="where robots come from: sim = built-in simulated fleet (default, no ROS needed), "
        "ros = a live ROS 2 graph through rclpy, bag = recorded topics",
    )
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine only; use 0.0.0.0 to serve the LAN)",
    )
    parser.add_argument("--port", type=int, default=8080, help="TCP port (default 8080; 0 picks a free one)")
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
    bag = parser.add_argument_group("recordings (--backend bag)")
    bag.add_argument(
        "--bag",
        action="append",
        default=[],
        metavar="[ROBOT=]PATH",
        help="a rosbag2 recording (sqlite3 or MCAP; a bag directory or file) to replay; ROBOT= binds it to a "
        "robot of the config, otherwise a bag of un-namespaced topics plays as the first robot not yet bound. "
        "Repeat for several robots",
    )
    bag.add_argument("--rate", type=float, default=1.0, help="replay speed factor (default 1.0)")
    bag.add_argument("--loop", action="store_true", help="start over at the end of the recordings")
    bag.add_argument("--start", type=float, default=0.0, metavar="SECONDS", help="start this far into the recordings")
    parser.add_argument("--version", action="version", version=f"xr-relay {__version__}")
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=getattr(logging, args.log_level.upper()),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    log = logging.getLogger("relay")
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        log.error("%s", exc)
        return EXIT_USAGE
    from .server import serve

    try:
        options = Options(
            backend=args.backend,
            host=args.host,
            port=args.port,
            bag=BagOptions(bags=tuple(args.bag), rate=args.rate, loop=args.loop, start=args.start),
            audit_log=args.audit_log or None,
        )
        asyncio.run(serve(config, options))
    except BackendUnavailable as exc:
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
