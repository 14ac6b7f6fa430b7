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
    parser.add_argument("--version", action="version", version=f"xr-relay {__version__}")
    return parser


def main(argv: list[str] | None = None) -> int:
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
        asyncio.run(serve(config, args.backend, args.host, args.port))
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
