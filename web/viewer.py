"""Same-origin access to a race's viser server: its client page and a websocket relay.

viser's browser client (one self-contained ``index.html`` shipped in the wheel) connects to the websocket at its
own page URL without the trailing slash. So the app serves that page at ``/races/{id}/viewer/`` and relays the
websocket at ``/races/{id}/viewer`` to the race's viser server on ``127.0.0.1:<port>``: viser stays on loopback,
and one port (and one TLS proxy) serves everything.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
from pathlib import Path

import viser
import websockets
from starlette.websockets import WebSocket, WebSocketDisconnect, WebSocketState
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidStatus
from websockets.typing import Subprotocol

log = logging.getLogger(__name__)

VISER_SUBPROTOCOL = f"viser-v{viser.__version__}"
CLOSE_UPSTREAM_UNAVAILABLE = 1011  # the race's viser server could not be reached
CLOSE_UNKNOWN_RACE = 4404  # used by web.routes for races without a viewer
CLOSE_TRY_AGAIN_LATER = 1013  # every replay scene the server allows is being watched


class ViewersBusyError(RuntimeError):
    """No 3D view can be opened now: as many as the server allows are open and watched."""


# [s] before that close: viser's client reconnects at once after any close, so an open tab of a race whose scene
# is gone would otherwise reconnect tens of times a second until viewer-live.js replaces the page
UNKNOWN_RACE_CLOSE_DELAY_S = 2.0


@functools.cache
def viewer_index_html() -> bytes:
    """viser's client page (``viser/client/build/index.html``), read once."""
    return (Path(viser.__file__).parent / "client" / "build" / "index.html").read_bytes()


@functools.cache
def viewer_page_with(script: str) -> bytes:
    """viser's client page that also loads the app's ``/assets/{script}`` (read once per script)."""
    page = viewer_index_html()
    tag = f'<script src="/assets/{script}" defer></script>'.encode()
    at = page.rfind(b"</head>")
    return page[:at] + tag + page[at:] if at >= 0 else page + tag


def requested_subprotocol(websocket: WebSocket) -> str | None:
    """The ``viser-v<version>`` subprotocol the browser asked for, if any."""
    for protocol in websocket.scope.get("subprotocols", []) or []:
        if isinstance(protocol, str) and protocol.startswith("viser-v"):
            return protocol
    return None


async def relay_viewer(websocket: WebSocket, port: int) -> None:
    """Relay a browser's viewer websocket to the viser server on ``127.0.0.1:port`` until either side ends.

    The browser's query string and ``viser-v<version>`` subprotocol are forwarded (viser closes mismatched
    versions with 1002, which is passed back); frames are pumped both ways by two tasks, and when one side
    closes the other is closed too. A normal browser disconnect logs nothing.
    """
    protocol = requested_subprotocol(websocket)
    subprotocols = [Subprotocol(protocol or VISER_SUBPROTOCOL)]
    query = websocket.url.query  # the scene reads its viewer's choices there (``follow``: web.scene)
    try:
        upstream = await websockets.connect(
            f"ws://127.0.0.1:{port}/" + (f"?{query}" if query else ""),
            subprotocols=subprotocols,
            max_size=None,
            compression=None,
            open_timeout=5,
            ping_interval=None,
        )
    except (OSError, InvalidHandshake, TimeoutError) as exc:
        status = exc.response.status_code if isinstance(exc, InvalidStatus) else None
        log.info("viewer relay: viser on port %d unavailable (%s %s)", port, type(exc).__name__, status or "")
        # accept first: a close before the handshake reaches the browser as a bare HTTP 403
        await websocket.accept(subprotocol=protocol)
        await websocket.close(code=CLOSE_UPSTREAM_UNAVAILABLE, reason="race viewer unavailable")
        return
    try:
        await websocket.accept(subprotocol=protocol)
        code, reason = await _pump(websocket, upstream)
    finally:
        await upstream.close()
    if websocket.client_state == WebSocketState.CONNECTED:
        with contextlib.suppress(Exception):
            await websocket.close(code=code, reason=reason)


async def _pump(websocket: WebSocket, upstream: websockets.ClientConnection) -> tuple[int, str]:
    """Copy frames both ways until one side ends; returns the close code and reason for the browser."""
    result: dict[str, tuple[int, str]] = {}

    async def down() -> None:  # viser -> browser
        try:
            async for message in upstream:
                if isinstance(message, bytes):
                    await websocket.send_bytes(message)
                else:
                    await websocket.send_text(message)
        except ConnectionClosed:
            pass
        result["close"] = (upstream.close_code or 1000, upstream.close_reason or "")

    async def up() -> None:  # browser -> viser
        try:
            while True:
                message = await websocket.receive()
                if message["type"] == "websocket.disconnect":
                    return
                data = message.get("bytes")
                await upstream.send(data if data is not None else message.get("text") or "")
        except (WebSocketDisconnect, ConnectionClosed):
            return

    tasks = [asyncio.create_task(down(), name="viewer-relay-down"), asyncio.create_task(up(), name="viewer-relay-up")]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        for outcome in await asyncio.gather(*tasks, return_exceptions=True):
            if isinstance(outcome, Exception) and not isinstance(
                outcome, (WebSocketDisconnect, ConnectionClosed, RuntimeError)
            ):
                log.warning("viewer relay: %s: %s", type(outcome).__name__, outcome)
    code, reason = result.get("close", (1000, ""))
    # 1005/1006 are "no status" / "abnormal" and may not be sent in a close frame
    return (1000 if code in (1005, 1006) else code), reason
