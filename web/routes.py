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

from fastapi import APIRouter, Request, WebSocket
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from web.viewer import CLOSE_UNKNOWN_RACE, relay_viewer, requested_subprotocol, viewer_index_html

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


@functools.cache
def _viewer_index_gzip() -> bytes:
    return gzip.compress(viewer_index_html(), compresslevel=6)


def _not_found_page(race_id: str) -> HTMLResponse:
    body = _static("notfound.html").decode().replace("{race_id}", _escape(race_id))
    return HTMLResponse(body, status_code=404, headers=NO_CACHE)


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def make_web_router(scene_port: Callable[[str], int | None]) -> APIRouter:
    """Routes of the web pages; ``scene_port(race_id)`` gives a race's viser port (``None``: no live viewer).

    * ``GET /``: the start page (races, results, launch form);
    * ``GET /assets/{name}``: the pages' scripts and styles;
    * ``GET /races/{race_id}/viewer/``: viser's client page (404 when the race has no live viewer);
      ``GET /races/{race_id}/viewer`` redirects there;
    * websocket ``/races/{race_id}/viewer``: relayed to the race's viser server (closed with 4404 when unknown);
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

    @router.get("/races/{race_id}/viewer/", response_class=HTMLResponse)
    def viewer_page(race_id: str, request: Request) -> Response:
        """viser's client page for a race with a live viewer."""
        if scene_port(race_id) is None:
            return _not_found_page(race_id)
        if "gzip" in request.headers.get("accept-encoding", ""):
            return Response(
                _viewer_index_gzip(),
                media_type="text/html; charset=utf-8",
                headers={**NO_CACHE, "Content-Encoding": "gzip", "Vary": "Accept-Encoding"},
            )
        return Response(viewer_index_html(), media_type="text/html; charset=utf-8", headers=NO_CACHE)

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
