"""The web pages: start page, race viewer (viser's client and its websocket relay), the drive page and the
tournament pages.

The router knows nothing about sessions: the app passes ``scene_port(race_id)``, which returns the port of the
race's live viser server or ``None``. The pages are static HTML + vanilla JS from ``web/static/`` that talk to the
server's JSON API (``/api/...``); nothing is loaded from outside the app.
"""

from __future__ import annotations

import functools
import gzip
import re
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

from fastapi import APIRouter, Request, WebSocket
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from web.viewer import (
    CLOSE_TRY_AGAIN_LATER,
    CLOSE_UNKNOWN_RACE,
    ViewersBusyError,
    relay_viewer,
    requested_subprotocol,
    viewer_page_with,
)

STATIC_DIR = Path(__file__).parent / "static"
ASSET_TYPES = {
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".html": "text/html; charset=utf-8",
    ".svg": "image/svg+xml",
}
_ASSET_NAME = re.compile(r"^[A-Za-z0-9_-]+\.(js|css|html|svg)$")
NO_CACHE = {"Cache-Control": "no-cache"}


@functools.cache
def _static(name: str) -> bytes:
    return (STATIC_DIR / name).read_bytes()


LIVE_VIEWER_SCRIPT = "viewer-switch.js"  # moves a live viewer to the replay once the race is over
REPLAY_VIEWER_SCRIPT = "replay-viewer.js"


class ReplayDirectory(Protocol):
    """Where stored races' replay scenes are found (the server's :mod:`server.replays`)."""

    async def has_replay(self, race_id: str) -> bool:
        """Whether ``race_id`` is over and has a stored replay."""

    async def replay_port(self, race_id: str) -> int | None:
        """The local port of the race's replay scene, opened if need be (``None``: no replay); raises
        :class:`web.viewer.ViewersBusyError` when no more scenes can be opened now."""

    def viewer_joined(self, race_id: str) -> None:
        """A browser's websocket is being relayed to the race's replay scene (it is watched)."""

    def viewer_left(self, race_id: str) -> None:
        """That websocket ended."""


@functools.cache
def _viewer_page_gzip(script: str) -> bytes:
    return gzip.compress(viewer_page_with(script), compresslevel=6)


def _viewer_page(script: str, request: Request) -> Response:
    """viser's client page with ``script``, gzip-compressed when the browser takes it."""
    if "gzip" in request.headers.get("accept-encoding", ""):
        return Response(
            _viewer_page_gzip(script),
            media_type="text/html; charset=utf-8",
            headers={**NO_CACHE, "Content-Encoding": "gzip", "Vary": "Accept-Encoding"},
        )
    return Response(viewer_page_with(script), media_type="text/html; charset=utf-8", headers=NO_CACHE)


def _not_found_page(race_id: str) -> HTMLResponse:
    body = _static("notfound.html").decode().replace("{race_id}", _escape(race_id))
    return HTMLResponse(body, status_code=404, headers=NO_CACHE)


def _message_page(title: str, text: str, race_id: str, status_code: int) -> HTMLResponse:
    body = (
        _static("message.html")
        .decode()
        .replace("{title}", _escape(title))
        .replace("{text}", _escape(text))
        .replace("{race_id}", _escape(race_id))
    )
    return HTMLResponse(body, status_code=status_code, headers=NO_CACHE)


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def make_web_router(scene_port: Callable[[str], int | None], replays: ReplayDirectory | None = None) -> APIRouter:
    """Routes of the web pages; ``scene_port(race_id)`` gives a race's viser port (``None``: no live viewer),
    ``replays`` the stored races' replay scenes (``None``: no replay player).

    * ``GET /``: the start page (races, results, launch form);
    * ``GET /assets/{name}``: the pages' scripts and styles;
    * ``GET /races/{race_id}``: the race's page (standings, laps, charts, incidents; its script reads the API);
    * ``GET /races/{race_id}/viewer/``: viser's client page (404 when the race has no live viewer; a race that is
      over with a replay redirects to its replay); ``GET /races/{race_id}/viewer`` redirects there;
    * websocket ``/races/{race_id}/viewer``: relayed to the race's viser server (closed with 4404 when unknown);
    * ``GET /races/{race_id}/replay/``: the replay player of a stored race (its scene opened on demand; 404 when
      the race has no replay, 503 when too many replays are watched); ``GET /races/{race_id}/replay`` redirects;
    * websocket ``/races/{race_id}/replay``: relayed to the race's replay scene (4404: no replay; 1013: busy);
    * ``GET /races/{race_id}/drive?kart=K&token=T``: the drive page (viewer + keyboard input);
    * ``GET /tournaments``: the tournaments page (stored tournaments, leaderboard, launch form);
    * ``GET /tournaments/{tournament_id}``: a tournament's page (progress, races, tables and plots).
    """
    router = APIRouter(include_in_schema=False)

    @router.get("/", response_class=HTMLResponse)
    def start_page() -> Response:
        """The start page."""
        return HTMLResponse(_static("index.html"), headers=NO_CACHE)

    @router.get("/assets/{name}")
    def asset(name: str) -> Response:
        """A script, style sheet or image of the pages."""
        if not _ASSET_NAME.match(name) or not (STATIC_DIR / name).is_file():
            return Response("not found", status_code=404, media_type="text/plain")
        return Response(_static(name), media_type=ASSET_TYPES[Path(name).suffix], headers=NO_CACHE)

    @router.get("/races/{race_id}/viewer")
    def viewer_redirect(race_id: str) -> Response:
        """The viewer lives at the slash form (viser's client derives its websocket URL from the page URL)."""
        return RedirectResponse(f"/races/{race_id}/viewer/", status_code=307)

    @router.get("/races/{race_id}", response_class=HTMLResponse)
    def race_page(race_id: str) -> Response:
        """A race's page (the id is read from the URL by its script, which says when there is no such race)."""
        return HTMLResponse(_static("race.html"), headers=NO_CACHE)

    @router.get("/races/{race_id}/viewer/", response_class=HTMLResponse)
    async def viewer_page(race_id: str, request: Request) -> Response:
        """viser's client page for a race with a live viewer; the replay once the race is over."""
        if replays is not None and await replays.has_replay(race_id):
            return RedirectResponse(f"/races/{race_id}/replay/", status_code=307)
        if scene_port(race_id) is None:
            return _not_found_page(race_id)
        return _viewer_page(LIVE_VIEWER_SCRIPT, request)

    _add_replay_routes(router, replays)

    @router.websocket("/races/{race_id}/viewer")
    async def viewer_socket(websocket: WebSocket, race_id: str) -> None:
        """The viewer's websocket, relayed to the race's viser server."""
        port = scene_port(race_id)
        if port is None:
            # accept first: a close before the handshake becomes a bare HTTP 403 without the code and reason
            await websocket.accept(subprotocol=requested_subprotocol(websocket))
            await websocket.close(code=CLOSE_UNKNOWN_RACE, reason=f"no live viewer for race {race_id}"[:120])
            return
        await relay_viewer(websocket, port)

    @router.get("/races/{race_id}/drive", response_class=HTMLResponse)
    def drive_page(race_id: str) -> Response:
        """The drive page (the race id, kart and token are read from the URL by its script)."""
        return HTMLResponse(_static("drive.html"), headers=NO_CACHE)

    @router.get("/tournaments", response_class=HTMLResponse)
    def tournaments_page() -> Response:
        """The tournaments page (its script reads ``/api/tournaments``)."""
        return HTMLResponse(_static("tournaments.html"), headers=NO_CACHE)

    @router.get("/tournaments/{tournament_id}", response_class=HTMLResponse)
    def tournament_page(tournament_id: str) -> Response:
        """A tournament's page (the id is read from the URL by its script, which says when there is none)."""
        return HTMLResponse(_static("tournament.html"), headers=NO_CACHE)

    return router


def _add_replay_routes(router: APIRouter, replays: ReplayDirectory | None) -> None:
    """The replay player's page and websocket (see :func:`make_web_router`)."""

    @router.get("/races/{race_id}/replay")
    def replay_redirect(race_id: str) -> Response:
        """The replay player lives at the slash form, as the viewer does."""
        return RedirectResponse(f"/races/{race_id}/replay/", status_code=307)

    @router.get("/races/{race_id}/replay/", response_class=HTMLResponse)
    async def replay_page(race_id: str, request: Request) -> Response:
        """viser's client page for a stored race's replay player (its scene opened now if need be)."""
        try:
            port = await replays.replay_port(race_id) if replays is not None else None
        except ViewersBusyError as exc:
            return _message_page("Replays busy", str(exc), race_id, 503)
        if port is None:
            return _message_page(
                "No replay",
                "This race does not exist, is not over yet, or has no stored replay.",
                race_id,
                404,
            )
        return _viewer_page(REPLAY_VIEWER_SCRIPT, request)

    @router.websocket("/races/{race_id}/replay")
    async def replay_socket(websocket: WebSocket, race_id: str) -> None:
        """The replay player's websocket, relayed to the race's replay scene."""
        try:
            port = await replays.replay_port(race_id) if replays is not None else None
        except ViewersBusyError as exc:
            await websocket.accept(subprotocol=requested_subprotocol(websocket))
            await websocket.close(code=CLOSE_TRY_AGAIN_LATER, reason=str(exc)[:120])
            return
        if port is None:
            await websocket.accept(subprotocol=requested_subprotocol(websocket))
            await websocket.close(code=CLOSE_UNKNOWN_RACE, reason=f"no replay for race {race_id}"[:120])
            return
        assert replays is not None  # (a port came from it)
        replays.viewer_joined(race_id)
        try:
            await relay_viewer(websocket, port)
        finally:
            replays.viewer_left(race_id)
