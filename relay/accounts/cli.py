"""``xr-relay users``: the site's accounts, on the users file directly (a running relay reads it at each sign-in).

    xr-relay users add NAME --role admin|operator|inspector|viewer [--password-stdin]
    xr-relay users passwd NAME [--password-stdin]
    xr-relay users role NAME ROLE
    xr-relay users remove NAME
    xr-relay users list
    (each with [--users FILE], default ./xr-relay-users.sqlite, as the relay's)

The password is asked twice at the terminal (never an argument: it would sit in the shell's history and in ``ps``),
or read from the first line of standard input with ``--password-stdin`` (scripts). A problem is one line naming it,
exit status 2, and nothing changes. A relay started on a users file that holds anyone asks everyone to sign in.
"""

from __future__ import annotations

import argparse
import getpass
import sys
from collections.abc import Sequence
from datetime import datetime

from .roles import ROLES
from .users import AccountError, UserBook

DEFAULT_USERS = "xr-relay-users.sqlite"
_PROG = "xr-relay users"


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    book = UserBook(args.users)
    try:
        if args.action == "add":
            user = book.add(args.name, args.role, _password(args))
            _say(f"added {user.name} ({user.role})")
        elif args.action == "passwd":
            book.set_password(args.name, _password(args))
            _say(f"changed the password of {args.name}; a running relay takes it at the next sign-in")
        elif args.action == "role":
            book.set_role(args.name, args.role)
            _say(f"{args.name} is now {args.role}; restart a running relay to end their sessions")
        elif args.action == "remove":
            book.remove(args.name)
            _say(f"removed {args.name}; restart a running relay to end their sessions")
        else:
            for user in book.users():
                created = datetime.fromtimestamp(user.created).astimezone().isoformat(timespec="seconds")
                print(f"{user.name}\t{user.role}\tsince {created}")  # noqa: T201
    except AccountError as exc:
        print(f"{_PROG}: {exc}", file=sys.stderr)  # noqa: T201
        return 2
    return 0


def _password(args: argparse.Namespace) -> str:
    if args.password_stdin:
        return sys.stdin.readline().rstrip("\r\n")
    first = getpass.getpass(f"password for {args.name}: ")
    if getpass.getpass("again: ") != first:
        raise AccountError("the two passwords differ")
    return first


def _say(text: str) -> None:
    print(f"{_PROG}: {text}")  # noqa: T201


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=_PROG, description="the accounts people sign in with (docs/security.md)")
    parser.add_argument("--users", default=DEFAULT_USERS, metavar="FILE", help=f"default ./{DEFAULT_USERS}")
    actions = parser.add_subparsers(dest="action", required=True)
    add = actions.add_parser("add", help="a new account")
    add.add_argument("name")
    add.add_argument("--role", required=True, choices=ROLES)
    add.add_argument("--password-stdin", action="store_true", help="read the password from standard input")
    passwd = actions.add_parser("passwd", help="a new password")
    passwd.add_argument("name")
    passwd.add_argument("--password-stdin", action="store_true", help="read the password from standard input")
    role = actions.add_parser("role", help="another role")
    role.add_argument("name")
    role.add_argument("role", choices=ROLES)
    remove = actions.add_parser("remove", help="remove an account")
    remove.add_argument("name")
    actions.add_parser("list", help="the accounts and their roles")
    return parser
