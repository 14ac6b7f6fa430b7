"""Secrets out of log lines: the password of a database URL (``postgresql://user:PASSWORD@host/db``, ``?password=``)
and an operator token in a query string (``?token=``), whatever module logs them.

The relay names a database by its URL without the password wherever it can (relay.inspection.store); this is the
net under that: the command line installs :class:`RedactingFilter` on its log handlers, so a line that names a URL
whole (a start-up line, a driver's message, a traceback) is written with ``***`` in its place. The start-up line
``inspection: ... database postgresql://relay:PASSWORD@...`` did write the password in full. A password need not be
in the URL at all: libpq reads ``PGPASSWORD`` and ``~/.pgpass`` (docs/inspection.md).
"""

from __future__ import annotations

import logging
import re

#: ``scheme://user:SECRET@``: the user part of a URL's authority, up to its last ``@`` before the host.
_USERINFO = re.compile(r"(?P<head>\b[A-Za-z][A-Za-z0-9+.-]*://[^\s:/?#@]*:)[^\s/?#]*(?=@)")
#: ``password=SECRET`` and ``token=SECRET`` in a query string or a libpq ``key=value`` string.
_PARAMETER = re.compile(r"(?P<head>\b(?:password|token)=)[^\s&#'\"]+", re.IGNORECASE)


def redact(text: str) -> str:
    """``text`` with every URL password and ``password=`` or ``token=`` value replaced by ``***``."""
    return _PARAMETER.sub(r"\g<head>***", _USERINFO.sub(r"\g<head>***", text))


class RedactingFilter(logging.Filter):
    """Rewrites each record's message (and its traceback) through :func:`redact` before a handler writes it."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        cleaned = redact(message)
        if cleaned != message:
            record.msg, record.args = cleaned, None
        if record.exc_info and not record.exc_text:
            record.exc_text = logging.Formatter().formatException(record.exc_info)
        if record.exc_text:
            record.exc_text = redact(record.exc_text)
        return True


def redact_logs(logger: logging.Logger | None = None) -> None:
    """Install :class:`RedactingFilter` on every handler of ``logger`` (default: the root logger)."""
    for handler in (logger or logging.getLogger()).handlers:
        if not any(isinstance(f, RedactingFilter) for f in handler.filters):
            handler.addFilter(RedactingFilter())
