"""Control leases: at most one operator controls a robot at a time (no I/O; time is passed in).

The first command (goal, cmd_vel, cancel) of an operator takes a free robot's lease; others get ``leased``
naming the holder until the lease is released: explicitly (``<robot>/lease`` with ``release``), when the
holder disconnects, or after ``idle_timeout`` seconds without commands while the robot is idle (a robot
still navigating to its holder's goal keeps its lease). Taking a held lease needs ``force``; the relay stops
the robot before any change of hands and tells every client.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class _Lease:
    holder: str
    last_command: float


class LeaseTable:
    def __init__(self, idle_timeout: float = 30.0) -> None:
        self.idle_timeout = idle_timeout
        self._leases: dict[str, _Lease] = {}

    def holder(self, robot: str) -> str | None:
        lease = self._leases.get(robot)
        return lease.holder if lease else None

    def use(self, robot: str, client: str, now: float) -> tuple[bool, str | None]:
        """A command of ``client`` for ``robot``: (allowed, holder before). Takes a free lease."""
        lease = self._leases.get(robot)
        if lease is None:
            self._leases[robot] = _Lease(client, now)
            return True, None
        if lease.holder != client:
            return False, lease.holder
        lease.last_command = now
        return True, client

    def take(self, robot: str, client: str, now: float) -> str | None:
        """Forced take-over (or a plain acquire); returns the previous holder, if another client."""
        previous = self.holder(robot)
        self._leases[robot] = _Lease(client, now)
        return previous if previous != client else None

    def release(self, robot: str, client: str) -> bool:
        """``client`` gives the lease back; False when it did not hold it."""
        lease = self._leases.get(robot)
        if lease is None or lease.holder != client:
            return False
        del self._leases[robot]
        return True

    def release_client(self, client: str) -> list[str]:
        robots = [robot for robot, lease in self._leases.items() if lease.holder == client]
        for robot in robots:
            del self._leases[robot]
        return robots

    def expired(self, now: float, busy: set[str]) -> list[str]:
        """Leases idle for ``idle_timeout`` on robots that are not ``busy`` (navigating or driven): released."""
        stale = [
            robot
            for robot, lease in self._leases.items()
            if robot not in busy and now - lease.last_command >= self.idle_timeout
        ]
        for robot in stale:
            del self._leases[robot]
        return stale

    def keep_alive(self, robot: str, now: float) -> None:
        """The robot is still busy for its holder (e.g. navigating): the idle clock restarts."""
        lease = self._leases.get(robot)
        if lease is not None:
            lease.last_command = now
