"""Run-time options of one relay process (from the command line), as opposed to the fleet (robots.yaml)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class BagOptions:
    """``--backend bag``: which recordings to replay and how."""

    #: ``PATH`` or ``ROBOT=PATH``, as given on the command line, in order.
    bags: tuple[str, ...] = ()
    rate: float = 1.0
    loop: bool = False
    start: float = 0.0  # seconds from the recordings' start


@dataclass(frozen=True)
class Options:
    backend: str = "sim"
    host: str = "127.0.0.1"
    port: int = 8080
    bag: BagOptions = field(default_factory=BagOptions)
    #: JSON-lines file of every command accepted or refused (relay/audit.py); None: no audit log.
    audit_log: str | None = None
