"""Password hashes: Argon2id (argon2-cffi, the reference implementation's binding), memory-hard, so a stolen users
file costs an attacker 64 MiB and a few tens of milliseconds per guess.

Checking takes that long on purpose: callers run it off the event loop, a few at a time (relay/net/sign_in.py). An
unknown user name is checked against a dummy hash of the same cost, so the answer's time does not tell which part
was wrong.
"""

from __future__ import annotations

from functools import cache
from typing import Final

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError, VerifyMismatchError

#: Fewest characters of a password: a person chooses it, so its length is what can be asked.
MIN_LENGTH: Final = 10
MAX_LENGTH: Final = 256

_HASHER = PasswordHasher()  # argon2-cffi's defaults: RFC 9106's second recommendation (64 MiB, t=3, p=4)


@cache
def _dummy() -> str:
    """The hash an unknown user name is checked against, made at the first such check: made at import, it cost every
    process that imports the relay (each ``xr-relay`` command, each relay a test starts) 0.1-0.3 s of CPU and 64 MiB."""
    return _HASHER.hash("not a password of anyone: compared with when the user name is unknown")


def check_new(password: str) -> None:
    """ValueError when ``password`` is too short or too long to set."""
    if len(password) < MIN_LENGTH:
        raise ValueError(f"a password needs at least {MIN_LENGTH} characters")
    if len(password) > MAX_LENGTH:
        raise ValueError(f"a password has at most {MAX_LENGTH} characters")


def hash_password(password: str) -> str:
    check_new(password)
    return _HASHER.hash(password)


def verify(stored: str | None, password: str) -> bool:
    """Whether ``password`` matches ``stored`` (None: an unknown user, checked against a dummy at the same cost)."""
    if len(password) > MAX_LENGTH:
        return False
    try:
        return _HASHER.verify(stored or _dummy(), password) and stored is not None
    except (VerifyMismatchError, VerificationError, InvalidHashError):
        return False
