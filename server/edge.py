"""The server's edge: what every HTTP request and websocket passes before a route sees it.

* :class:`BodyLimit`: a request body over ``max_body_bytes`` gets 413 before it is read whole (a larger
  ``Content-Length`` at once, a longer chunked body as soon as the count passes the limit).
* :class:`HostOriginGuard`: the ``Host`` header must name a served host (:meth:`Settings.served_hosts`), and an
  ``Origin`` header, where a browser sends one, an allowed origin; otherwise HTTP gets 400 / 403 and a websocket
  is closed with 4400 / 4403 and the reason. This stops DNS rebinding and other sites' pages driving the API.
* CORS (Starlette's ``CORSMiddleware``) for ``cors_origins`` only.
* :func:`validation_error_answer`: a 422 that never echoes unbounded or unencodable input.

:func:`install_edge` puts them on the app.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from typing import Any
from urllib.parse import urlsplit

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.datastructures import Headers
from starlette.middleware.cors import CORSMiddleware
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from server.models import CLOSE_BAD_REQUEST, CLOSE_FORBIDDEN
from server.settings import Settings

SHOWN_CHARS = 120  # an echoed string is cut to this many characters
SHOWN_ITEMS = 8  # an echoed list or object with more entries is summarised
SHOWN_DEPTH = 3
SHOWN_ERRORS = 20  # a 422 lists at most this many problems (then how many more)
MESSAGE_CHARS = 600  # messages are the server's own, naming at most a short input and a list of names
MAX_CLOSE_REASON_BYTES = 123  # RFC 6455: a close frame's reason


# ------------------------------------------------------------------------------------------- 422 answers
def _cut(text: str, limit: int) -> str:
    text = text.encode("utf-8", "backslashreplace").decode("utf-8")  # lone surrogates become \\udXXX
    return f"{text[:limit]}... ({len(text)} characters)" if len(text) > limit else text


def bounded(value: Any, depth: int = 0) -> Any:
    """``value`` made safe to echo in an error: short, JSON-encodable, finite, valid Unicode."""
    if isinstance(value, bool) or value is None:
        return value
    if isinstance(value, int):
        return value if abs(value) < 10**18 else _cut(str(value), SHOWN_CHARS)
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, bytes):
        return _cut(value.decode("utf-8", "replace"), SHOWN_CHARS)
    if isinstance(value, str):
        return _cut(value, SHOWN_CHARS)
    if isinstance(value, dict | list | tuple):
        if len(value) > SHOWN_ITEMS or depth >= SHOWN_DEPTH:
            kind = "an object" if isinstance(value, dict) else "a list"
            return f"({kind} of {len(value)} entries, not shown)"
        if isinstance(value, dict):
            return {_cut(str(k), SHOWN_CHARS): bounded(v, depth + 1) for k, v in value.items()}
        return [bounded(v, depth + 1) for v in value]
    return _cut(str(value), SHOWN_CHARS)


def bounded_error(error: dict[str, Any]) -> dict[str, Any]:
    """One pydantic / FastAPI error entry with its location, message, input and context bounded."""
    out: dict[str, Any] = {
        "type": _cut(str(error.get("type", "value_error")), SHOWN_CHARS),
        "loc": [
            p if isinstance(p, int) and not isinstance(p, bool) else _cut(str(p), SHOWN_CHARS) for p in error["loc"]
        ],
        "msg": _cut(str(error.get("msg", "")), MESSAGE_CHARS),
    }
    if "input" in error:
        out["input"] = bounded(error["input"])
    ctx = error.get("ctx")
    if isinstance(ctx, dict):
        out["ctx"] = {
            _cut(str(k), SHOWN_CHARS): bounded(v if isinstance(v, int | float | str) else str(v))
            for k, v in ctx.items()
        }
    return out


async def validation_error_answer(request: Request, exc: Exception) -> JSONResponse:
    """422 listing what was wrong (FastAPI's shape), each echoed value bounded (:func:`bounded`)."""
    assert isinstance(exc, RequestValidationError)
    errors = exc.errors()
    detail = [bounded_error(dict(e)) for e in errors[:SHOWN_ERRORS]]
    if len(errors) > SHOWN_ERRORS:
        more = len(errors) - SHOWN_ERRORS
        detail.append({"type": "too_many_errors", "loc": ["body"], "msg": f"and {more} more errors, not shown"})
    return JSONResponse({"detail": detail}, status_code=422)


# ------------------------------------------------------------------------------------------- body size
def _json_answer(status: int, detail: str) -> list[Message]:
    body = json.dumps({"detail": detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
    return [
        {"type": "http.response.start", "status": status, "headers": headers},
        {"type": "http.response.body", "body": body},
    ]


class BodyLimit:
    """413 for a request body over ``max_bytes``, decided before the body is read whole."""

    def __init__(self, app: ASGIApp, max_bytes: int) -> None:
        self.app = app
        self.max_bytes = max_bytes

    def _too_large(self, size: str) -> list[Message]:
        return _json_answer(413, f"the request body ({size}) is over the limit of {self.max_bytes} bytes")

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Refuse at once on ``Content-Length``, else count the body as it arrives."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = Headers(scope=scope).get("content-length")
        if declared is not None and declared.isascii() and declared.isdigit() and int(declared) > self.max_bytes:
            for message in self._too_large(f"{int(declared)} bytes"):
                await send(message)
            return
        received = 0
        refused = False
        started = False

        async def counted_receive() -> Message:
            nonlocal received, refused
            if refused:
                return {"type": "http.disconnect"}
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_bytes:
                    refused = True
                    if not started:
                        for answer in self._too_large(f"over {self.max_bytes} bytes so far"):
                            await send(answer)
                    # the app sees a client that went away and stops reading
                    return {"type": "http.disconnect"}
            return message

        async def guarded_send(message: Message) -> None:
            nonlocal started
            if refused:
                return  # the 413 is the answer
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        await self.app(scope, counted_receive, guarded_send)


# ------------------------------------------------------------------------------------------- host and origin
def host_name(host_header: str) -> str:
    """The name in a ``Host`` header, without the port (IPv6 literals without their brackets), lower case."""
    host = host_header.strip().lower()
    if host.startswith("["):
        return host[1 : host.find("]")] if "]" in host else host
    return host.rsplit(":", 1)[0] if host.count(":") == 1 else host


def name_allowed(name: str, patterns: Iterable[str]) -> bool:
    """Whether ``name`` matches a served-host pattern: ``*``, ``*.example.org`` or the exact name."""
    for pattern in patterns:
        pattern = pattern.strip("[]")
        if pattern == "*" or name == pattern:
            return True
        if pattern.startswith("*.") and name.endswith(pattern[1:]):
            return True
    return False


class HostOriginGuard:
    """Refuse requests and websockets for other hosts or from other sites' pages (see the module docstring)."""

    def __init__(self, app: ASGIApp, hosts: list[str], origins: list[str]) -> None:
        self.app = app
        self.hosts = hosts
        self.origins = {o.rstrip("/").lower() for o in origins}

    def refusal(self, headers: Headers) -> tuple[int, str] | None:
        """``(HTTP status, reason)`` when the request may not be served, else ``None``."""
        host = host_name(headers.get("host", ""))
        if not name_allowed(host, self.hosts):
            return 400, f"host {host[:60]!r} is not served here (allowed_hosts)"
        origin = headers.get("origin")
        if origin is not None and not self.origin_allowed(origin):
            return 403, f"origin {origin[:60]!r} is not allowed (allowed_origins)"
        return None

    def origin_allowed(self, origin: str) -> bool:
        """An origin on a served host, or one listed in ``allowed_origins`` / ``cors_origins``."""
        origin = origin.strip().rstrip("/").lower()
        if origin in self.origins:
            return True
        try:
            parts = urlsplit(origin)
        except ValueError:
            return False
        return (
            parts.scheme in ("http", "https")
            and bool(parts.hostname)
            and name_allowed(parts.hostname or "", self.hosts)
        )

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass what may be served; answer the rest here."""
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        refusal = self.refusal(Headers(scope=scope))
        if refusal is None:
            await self.app(scope, receive, send)
            return
        status, reason = refusal
        if scope["type"] == "http":
            for message in _json_answer(status, reason):
                await send(message)
            return
        # accept first: a close before the handshake is a bare HTTP 403 without the code and reason
        await receive()  # websocket.connect
        subprotocols = scope.get("subprotocols") or []
        await send({"type": "websocket.accept", "subprotocol": subprotocols[0] if subprotocols else None})
        code = CLOSE_BAD_REQUEST if status == 400 else CLOSE_FORBIDDEN
        reason_bytes = reason.encode()[:MAX_CLOSE_REASON_BYTES]
        await send({"type": "websocket.close", "code": code, "reason": reason_bytes.decode("utf-8", "ignore")})


def install_edge(app: FastAPI, settings: Settings) -> None:
    """Put the edge on ``app``: CORS (innermost, when configured), the host and origin guard, the body limit
    (outermost), and the bounded 422 answer."""
    app.add_exception_handler(RequestValidationError, validation_error_answer)
    if settings.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=settings.cors_origins,
            allow_methods=["GET", "POST"],
            allow_headers=["Content-Type", "X-API-Key"],
        )
    app.add_middleware(
        HostOriginGuard,
        hosts=settings.served_hosts(),
        origins=[*settings.allowed_origins, *settings.cors_origins],
    )
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
