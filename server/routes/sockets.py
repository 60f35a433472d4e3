"""What every websocket of the API shares: typed connection parameters, refusals with a close code and a reason,
and bounded inbound messages.

* Parameters: the path's race id and the query string are validated by one pydantic model per socket
  (:class:`DriveParams`, :class:`TelemetryParams`); anything malformed is refused with 4400 and what was wrong,
  never an exception.
* Inbound messages: every socket keeps reading (so a client's close frame is answered and nothing piles up
  in the server's buffers); a message over the socket's limit closes it with 1009 and the limit as reason. A
  read-only socket drains what it is sent. The server-wide ``ws_max_message_bytes`` (uvicorn's ``ws_max_size``)
  bounds what is assembled before a handler sees it.
* One :class:`SocketWriter` per connection: the sending task and the reader's replies share the socket under a
  lock, and closing twice is harmless.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Awaitable, Callable, Coroutine, Mapping
from typing import Any, TypeVar

from fastapi import WebSocket, WebSocketDisconnect
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from server.models import CLOSE_BAD_REQUEST, CLOSE_TOO_BIG

MAX_REASON_BYTES = 123  # RFC 6455: a close frame's reason fits in 123 bytes of UTF-8
MAX_RACE_ID_CHARS = 64
MAX_TOKEN_CHARS = 64  # tokens are 22 characters (secrets.token_urlsafe(16))
MAX_KART_INDEX = 7  # races have at most 8 karts (server.models.RaceIn)

ParamsT = TypeVar("ParamsT", bound=BaseModel)


class SocketParams(BaseModel):
    """Parameters every race socket has: the race id of its path. Unknown query parameters are ignored."""

    model_config = ConfigDict(extra="ignore", frozen=True)

    race_id: str = Field(min_length=1, max_length=MAX_RACE_ID_CHARS, pattern=r"^[A-Za-z0-9_-]+$")


class TelemetryParams(SocketParams):
    """``/api/races/{race_id}/telemetry`` takes no query parameters."""


class DriveParams(SocketParams):
    """``/api/races/{race_id}/drive?kart=K&token=T``."""

    kart: int = Field(ge=0, le=MAX_KART_INDEX, strict=False, description="the human kart's index")
    token: str = Field(min_length=1, max_length=MAX_TOKEN_CHARS, description="the kart's drive token")
    view: int = Field(
        0,
        ge=0,
        le=1,
        strict=False,
        description="1: a page with a 3D view, which sends {'type': 'ready'} once it has loaded (the start waits)",
    )


class RefusedError(Exception):
    """A connection refused with ``code`` and ``reason`` (raised by the checks, answered by :func:`refuse`)."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code
        self.reason = reason


def close_reason(text: str) -> str:
    """``text`` cut to fit a close frame (at most 123 bytes of UTF-8, never half a character)."""
    data = text.encode("utf-8", errors="replace")
    if len(data) <= MAX_REASON_BYTES:
        return text
    return data[: MAX_REASON_BYTES - 3].decode("utf-8", errors="ignore") + "..."


def describe(exc: ValidationError) -> str:
    """The errors of ``exc`` in one short line (``where: what``; never the input itself)."""
    parts = []
    for error in exc.errors(include_input=False, include_url=False):
        where = ".".join(str(p) for p in error["loc"]) or "message"
        parts.append(f"{where}: {error['msg']}")
    return "; ".join(parts)


def socket_params(model: type[ParamsT], websocket: WebSocket, path: Mapping[str, str]) -> ParamsT:
    """The socket's parameters (``path`` values and the query string) as ``model``; raises :class:`RefusedError`
    with 4400 and what was wrong. A repeated query parameter counts once (its first value)."""
    query: dict[str, Any] = {}
    for key, value in websocket.query_params.multi_items():
        query.setdefault(key, value)
    try:
        return model.model_validate({**query, **path})
    except ValidationError as exc:
        raise RefusedError(CLOSE_BAD_REQUEST, describe(exc)) from None


async def refuse(websocket: WebSocket, code: int, reason: str) -> None:
    """Close an accepted websocket with ``code`` and ``reason`` (cut to fit)."""
    with contextlib.suppress(RuntimeError, WebSocketDisconnect):
        await websocket.close(code=code, reason=close_reason(reason))


class SocketWriter:
    """Sends on one websocket from several tasks (one at a time); :meth:`close` once, later calls do nothing."""

    def __init__(self, websocket: WebSocket) -> None:
        self.websocket = websocket
        self._lock = asyncio.Lock()
        self.closed = False

    async def send_text(self, text: str) -> None:
        """Send a text message (nothing once closed)."""
        async with self._lock:
            if not self.closed:
                await self.websocket.send_text(text)

    async def close(self, code: int, reason: str) -> None:
        """Close the socket with ``code`` and ``reason`` (cut to fit), unless it is closed already."""
        async with self._lock:
            if self.closed:
                return
            self.closed = True
            await refuse(self.websocket, code, reason)


def message_size(message: Mapping[str, Any]) -> int:
    """[bytes] of a ``websocket.receive`` message's payload (text counted as UTF-8)."""
    text = message.get("text")
    if text is not None:
        return len(text.encode("utf-8", errors="replace"))
    data = message.get("bytes")
    return len(data) if data is not None else 0


def message_text(message: Mapping[str, Any]) -> str:
    """A ``websocket.receive`` message as text (binary frames decoded as UTF-8, bad bytes replaced)."""
    text = message.get("text")
    if text is not None:
        return str(text)
    return bytes(message.get("bytes") or b"").decode("utf-8", errors="replace")


async def serve_socket(
    writer: SocketWriter,
    sending: Coroutine[Any, Any, None],
    *,
    max_message_bytes: int,
    on_message: Callable[[str], Awaitable[None]] | None = None,
) -> None:
    """Run a connection: ``sending`` (the server's messages) in a task while this reads the client's messages
    until either side ends. Each message goes to ``on_message`` (``None``: a read-only socket, the message is
    dropped); one over ``max_message_bytes`` closes the socket with 1009. The sending task is cancelled when the
    client goes away."""
    websocket = writer.websocket
    sender = asyncio.get_running_loop().create_task(sending)
    try:
        while True:
            message = await websocket.receive()
            if message["type"] == "websocket.disconnect":
                return
            size = message_size(message)
            if size > max_message_bytes:
                await writer.close(CLOSE_TOO_BIG, f"message too big ({size} bytes, at most {max_message_bytes})")
                continue  # read on until the client answers the close
            if on_message is not None:
                await on_message(message_text(message))
    except (WebSocketDisconnect, RuntimeError):
        return  # the client went away, or the socket was closed under this read
    finally:
        sender.cancel()
        with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError, OSError):
            await sender
