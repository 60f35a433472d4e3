"""Drive tokens never reach the log.

A human kart's token travels in a query string (``/api/races/{id}/drive?kart=0&token=...`` for the websocket
and the drive page), and uvicorn writes request targets with their query strings: the access log for HTTP, its
``uvicorn.error`` logger for websockets ("WebSocket /path?query" [accepted]). :class:`TokenRedactor`, a logging
filter installed on those loggers by :func:`install_token_redaction`, replaces every ``token=VALUE`` (and other
secret-named parameters) in a record's message and arguments with ``token=[redacted]`` before any handler
formats it.
"""

from __future__ import annotations

import logging
import re
from typing import Any

REDACTED = "[redacted]"
# query parameters whose values are secrets, wherever they appear in a logged string
_SECRET_PARAMETER = re.compile(r"(?i)((?:^|[?&;\s\"'])(?:token|api_key|apikey|key)=)[^&\s\"'#]*")
UVICORN_LOGGERS = ("uvicorn.access", "uvicorn.error", "uvicorn")


def redact(text: str) -> str:
    """``text`` with the value of every secret query parameter replaced."""
    return _SECRET_PARAMETER.sub(lambda m: m.group(1) + REDACTED, text)


def _redact_value(value: Any) -> Any:
    if isinstance(value, str):
        return redact(value)
    if isinstance(value, bytes):
        return redact(value.decode("latin-1")).encode("latin-1")
    return value


class TokenRedactor(logging.Filter):
    """Redacts secret query parameters in a record (keeps it: this filter never drops a line)."""

    def filter(self, record: logging.LogRecord) -> bool:
        """Rewrite ``record``'s message and arguments in place; always True."""
        if isinstance(record.msg, str):
            record.msg = redact(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(_redact_value(a) for a in record.args)
        elif isinstance(record.args, dict):
            record.args = {k: _redact_value(v) for k, v in record.args.items()}
        return True


def install_token_redaction(logger_names: tuple[str, ...] = UVICORN_LOGGERS) -> None:
    """Add one :class:`TokenRedactor` to each named logger (again: nothing more)."""
    for name in logger_names:
        logger = logging.getLogger(name)
        if not any(isinstance(f, TokenRedactor) for f in logger.filters):
            logger.addFilter(TokenRedactor())
