"""robots.yaml's ``inspection.webhooks``: where alerts are POSTed, with the secret that signs them.

Each entry is ``{url, secret | secret_env, events}``: ``url`` is http:// or https://; ``secret`` is the shared secret
itself, or ``secret_env`` the environment variable holding it (so that it stays out of the file); ``events``, when
given, the alert kinds and ``alert.acknowledged`` the endpoint wants. Errors name the file, the line and the field
like every other (relay.config), and never show a secret, nor a URL (one may carry a password or a token).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from urllib.parse import urlsplit

from yaml.nodes import Node, ScalarNode

from ..inspection.records import ALERT_ACKNOWLEDGED, ALERT_KINDS
from .model import Webhook
from .reader import _Reader

#: Shortest secret: HMAC-SHA256 with fewer than 16 characters is guessable offline from one signed request.
MIN_SECRET = 16
_ENV_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,127}$")
EVENTS = (*ALERT_KINDS, ALERT_ACKNOWLEDGED)


def webhooks(reader: _Reader, node: Node, environ: Mapping[str, str] = os.environ) -> tuple[Webhook, ...]:
    path = "inspection.webhooks"
    found: list[Webhook] = []
    for index, entry in reader.sequence(node, path):
        here = f"{path}[{index}]"
        fields = reader.mapping(entry, here, ("url", "secret", "secret_env", "events"), required=("url",))
        found.append(Webhook(_url(reader, fields["url"], f"{here}.url"), _secret(reader, entry, fields, here, environ),
                             _events(reader, fields.get("events"), f"{here}.events")))  # fmt: skip
    return tuple(found)


def _url(reader: _Reader, node: Node, path: str) -> str:
    """An http(s) URL with a host. The error says what was wrong with it, never the URL itself."""
    value = reader.value(node) if isinstance(node, ScalarNode) else None
    if not isinstance(value, str):
        raise reader.fail(node, path, f"expected an http:// or https:// URL, got {reader.show(node)}")
    try:
        parts = urlsplit(value)
        host = parts.hostname
    except ValueError:  # a malformed port or bracket
        host = None
        parts = urlsplit("")
    scheme = parts.scheme.lower()
    if scheme not in ("http", "https"):
        got = f"a {scheme}: URL" if scheme else "no scheme"
        raise reader.fail(node, path, f"expected an http:// or https:// URL, got {got}")
    if not host:
        raise reader.fail(node, path, "expected an http:// or https:// URL with a host name or address")
    return value


def _secret(reader: _Reader, entry: Node, fields: Mapping[str, Node], path: str, environ: Mapping[str, str]) -> str:
    if ("secret" in fields) == ("secret_env" in fields):
        raise reader.fail(
            entry, path, "give exactly one of secret (the shared secret) or secret_env (a variable's name)"
        )
    if "secret" in fields:
        node = fields["secret"]
        value = reader.value(node) if isinstance(node, ScalarNode) else None
        where = f"{path}.secret"
    else:
        node = fields["secret_env"]
        name = reader.string(node, f"{path}.secret_env", pattern=_ENV_NAME, expected="an environment variable's name")
        value = environ.get(name)
        where = f"{path}.secret_env"
        if not value:
            raise reader.fail(node, where, f"the environment variable {name} is not set (or empty)")
    if not isinstance(value, str) or len(value) < MIN_SECRET:
        # Never shown: a secret too short is still a secret.
        raise reader.fail(node, where, f"expected a secret of at least {MIN_SECRET} characters (not shown here)")
    return value


def _events(reader: _Reader, node: Node | None, path: str) -> tuple[str, ...] | None:
    if node is None:
        return None
    events = []
    for index, item in reader.sequence(node, path):
        events.append(reader.choice(item, f"{path}[{index}]", EVENTS))
    if not events:
        raise reader.fail(node, path, "expected at least one event (leave events out for every event)")
    return tuple(events)
