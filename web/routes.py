"""The web pages: start page, race viewer (viser's client and its websocket relay), the drive page and the
tournament pages.

The router knows nothing about sessions: the app passes ``scene_port(race_id)``, which returns the port of the
race's live viser server or ``None``, and ``race_state(race_id)``, which says whether the race exists and is over.
The pages are static HTML + vanilla JS from ``web/static/`` that talk to the server's JSON API (``/api/...``);
nothing is loaded from outside the app.

A race's viewer URL answers one of three pages, so that no page reloads itself in a loop: viser's client while
the race's scene is open; a page that waits for the scene while the race is starting (it reloads once the API
says the view is open, at most once in 10 s); and a "race over" page, with no polling, once the scene is closed.
The viser page gets ``viewer-live.js``, which stops viser's reconnecting and loads that "race over" page when the
scene closes.
"""

from __future__ import annotations

import asyncio
import functools
import gzip
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fastapi import APIRouter, Request, WebSocket
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from web.viewer import (
    CLOSE_UNKNOWN_RACE,
    UNKNOWN_RACE_CLOSE_DELAY_S,
    relay_viewer,
    requested_subprotocol,
    viewer_index_html,
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


@functools.cache
def _viewer_index_gzip() -> bytes:
    return gzip.compress(live_viewer_html(), compresslevel=6)


# viser's client runs its websocket in a Worker: viewer-live.js must wrap Worker before viser's module script runs
VIEWER_LIVE_SCRIPT = b'<script src="/assets/viewer-live.js"></script>'


@dataclass(frozen=True)
class RaceState:
    """What the pages need to know of a race: its status (as the API shows it) and whether it is over."""

    status: str
    over: bool


def _page(name: str, status_code: int = 200, **values: str) -> HTMLResponse:
    """``web/static/NAME`` with each ``{key}`` replaced by its value, HTML-escaped."""
    body = _static(name).decode()
    for key, value in values.items():
        body = body.replace("{" + key + "}", _escape(value))
    return HTMLResponse(body, status_code=status_code, headers=NO_CACHE)


def _no_such_race(race_id: str) -> HTMLResponse:
    return _page("notfound.html", 404, race_id=race_id)


@functools.cache
def live_viewer_html() -> bytes:
    """viser's client page with ``viewer-live.js`` loaded first."""
    html = viewer_index_html()
    head = html.find(b"<head>")
    if head < 0:  # not the page this was written for: load the script first all the same
        return VIEWER_LIVE_SCRIPT + html
    at = head + len(b"<head>")
    return html[:at] + VIEWER_LIVE_SCRIPT + html[at:]


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def _without_scene(race_id: str, state: RaceState | None) -> HTMLResponse:
    """A race's viewer URL when the race has no open scene: no such race, the race is over, or it starts."""
    if state is None:
        return _no_such_race(race_id)
    if state.over:
        return _page("race-over.html", race_id=race_id, status=state.status)
    return _page("viewer-wait.html", race_id=race_id, status=state.status)


def _viser_page(request: Request) -> Response:
    """viser's client page (with ``viewer-live.js``), gzipped when the browser takes it."""
    if "gzip" in request.headers.get("accept-encoding", ""):
        return Response(
            _viewer_index_gzip(),
            media_type="text/html; charset=utf-8",
            headers={**NO_CACHE, "Content-Encoding": "gzip", "Vary": "Accept-Encoding"},
        )
    return Response(live_viewer_html(), media_type="text/html; charset=utf-8", headers=NO_CACHE)


def make_web_router(
    scene_port: Callable[[str], int | None], race_state: Callable[[str], RaceState | None]
) -> APIRouter:
    """Routes of the web pages; ``scene_port(race_id)`` gives a race's viser port (``None``: no live viewer) and
    ``race_state(race_id)`` its state (``None``: no such race; a blocking call, made in a worker thread).

    * ``GET /``: the start page (races, results, launch form);
    * ``GET /assets/{name}``: the pages' scripts and styles;
    * ``GET /races/{race_id}/viewer/``: viser's client page while the race's scene is open; otherwise a page that
      waits for it (race starting), says the race is over (with links to its result and replay) or, with 404,
      that there is no such race; ``GET /races/{race_id}/viewer`` redirects there;
    * websocket ``/races/{race_id}/viewer``: relayed to the race's viser server (closed with 4404 when there is
      no scene, after :data:`~web.viewer.UNKNOWN_RACE_CLOSE_DELAY_S`, which slows viser's reconnecting);
    * ``GET /races/{race_id}/drive?kart=K&token=T``: the drive page (viewer + keyboard input; 404 page for an
      unknown race);
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
        """viser's client page for a race with a live viewer; else what became of the race (see above)."""
        if scene_port(race_id) is None:
            return _without_scene(race_id, race_state(race_id))
        return _viser_page(request)

    @router.websocket("/races/{race_id}/viewer")
    async def viewer_socket(websocket: WebSocket, race_id: str) -> None:
        """The viewer's websocket, relayed to the race's viser server."""
        port = scene_port(race_id)
        if port is None:
            # accept first: a close before the handshake becomes a bare HTTP 403 without the code and reason
            await websocket.accept(subprotocol=requested_subprotocol(websocket))
            await asyncio.sleep(UNKNOWN_RACE_CLOSE_DELAY_S)
            await websocket.close(code=CLOSE_UNKNOWN_RACE, reason=f"no live viewer for race {race_id}"[:120])
            return
        await relay_viewer(websocket, port)

    @router.get("/races/{race_id}/drive", response_class=HTMLResponse)
    def drive_page(race_id: str) -> Response:
        """The drive page (the race id, kart and token are read from the URL by its script)."""
        if race_state(race_id) is None:
            return _no_such_race(race_id)
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
