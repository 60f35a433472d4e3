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
from typing import Protocol

from fastapi import APIRouter, Request, WebSocket
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from web.viewer import (
    CLOSE_TRY_AGAIN_LATER,
    CLOSE_UNKNOWN_RACE,
    UNKNOWN_RACE_CLOSE_DELAY_S,
    ViewersBusyError,
    relay_viewer,
    requested_subprotocol,
    viewer_index_html,
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
def _gzipped(page: bytes) -> bytes:
    return gzip.compress(page, compresslevel=6)


def _viser_page(page: bytes, request: Request) -> Response:
    """A viser client ``page`` (the live view's or the replay player's), gzip-compressed when the browser takes
    it."""
    if "gzip" in request.headers.get("accept-encoding", ""):
        return Response(
            _gzipped(page),
            media_type="text/html; charset=utf-8",
            headers={**NO_CACHE, "Content-Encoding": "gzip", "Vary": "Accept-Encoding"},
        )
    return Response(page, media_type="text/html; charset=utf-8", headers=NO_CACHE)


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


def _without_scene(race_id: str, state: RaceState | None) -> HTMLResponse:
    """A race's viewer URL when the race has no open scene: no such race, the race is over, or it starts."""
    if state is None:
        return _no_such_race(race_id)
    if state.over:
        return _page("race-over.html", race_id=race_id, status=state.status)
    return _page("viewer-wait.html", race_id=race_id, status=state.status)


# pages served as they are: their scripts read the API (the start page, the tournaments and the scenarios)
PLAIN_PAGES = {"/": "index.html", "/tournaments": "tournaments.html", "/scenarios": "scenarios.html"}


def _plain_page(name: str) -> Callable[[], Response]:
    def page() -> Response:
        return HTMLResponse(_static(name), headers=NO_CACHE)

    page.__doc__ = f"The page {name}."
    return page


def make_web_router(
    scene_port: Callable[[str], int | None],
    race_state: Callable[[str], RaceState | None],
    replays: ReplayDirectory | None = None,
    tournament_known: Callable[[str], bool] | None = None,
) -> APIRouter:
    """Routes of the web pages; ``scene_port(race_id)`` gives a race's viser port (``None``: no live viewer),
    ``race_state(race_id)`` its state (``None``: no such race; a blocking call, made in a worker thread),
    ``replays`` the stored races' replay scenes (``None``: no replay player) and ``tournament_known(id)`` whether
    a tournament exists (blocking, made in a worker thread; ``None``: every id is served its page).

    A page of something that does not exist answers 404, with a page that says so.

    * ``GET /``: the start page (races, results, launch form);
    * ``GET /assets/{name}``: the pages' scripts and styles;
    * ``GET /races/{race_id}``: the race's page (standings, laps, charts, incidents; its script reads the API;
      404 for an unknown race, with the same page, whose script says there is no such race);
    * ``GET /races/{race_id}/viewer/``: a race over with a stored replay redirects to its replay player; else
      viser's client page while the race's scene is open; otherwise a page that waits for it (race starting),
      says the race is over (with links to its result and replay) or, with 404, that there is no such race;
      ``GET /races/{race_id}/viewer`` redirects there;
    * websocket ``/races/{race_id}/viewer``: relayed to the race's viser server (closed with 4404 when there is
      no scene, after :data:`~web.viewer.UNKNOWN_RACE_CLOSE_DELAY_S`, which slows viser's reconnecting);
    * ``GET /races/{race_id}/replay/``: the replay player of a stored race (its scene opened on demand; 404 when
      the race has no replay, 503 when too many replays are watched); ``GET /races/{race_id}/replay`` redirects;
    * websocket ``/races/{race_id}/replay``: relayed to the race's replay scene (4404: no replay; 1013: busy);
    * ``GET /races/{race_id}/drive?kart=K&token=T``: the drive page (viewer + keyboard input; 404 page for an
      unknown race);
    * ``GET /tournaments``: the tournaments page (stored tournaments, leaderboard, launch form);
    * ``GET /scenarios``: the scenarios page (runs, a run's cells and pass thresholds, launch form);
    * ``GET /tournaments/{tournament_id}``: a tournament's page (progress, races, tables and plots; 404 for an
      unknown tournament, with the same page, whose script says there is no such tournament).
    """
    router = APIRouter(include_in_schema=False)
    for path, page in PLAIN_PAGES.items():
        router.add_api_route(path, _plain_page(page), methods=["GET"], response_class=HTMLResponse)

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
    async def race_page(race_id: str) -> Response:
        """A race's page (the id is read from the URL by its script, which says when there is no such race)."""
        known = await asyncio.to_thread(race_state, race_id) is not None
        return HTMLResponse(_static("race.html"), status_code=200 if known else 404, headers=NO_CACHE)

    @router.get("/races/{race_id}/viewer/", response_class=HTMLResponse)
    async def viewer_page(race_id: str, request: Request) -> Response:
        """The replay once the race is over and recorded; viser's client page for a race with a live viewer;
        else what became of the race (see above)."""
        if replays is not None and await replays.has_replay(race_id):
            return RedirectResponse(f"/races/{race_id}/replay/", status_code=307)
        if scene_port(race_id) is None:
            return _without_scene(race_id, await asyncio.to_thread(race_state, race_id))
        return _viser_page(live_viewer_html(), request)

    _add_replay_routes(router, replays)

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

    @router.get("/tournaments/{tournament_id}", response_class=HTMLResponse)
    async def tournament_page(tournament_id: str) -> Response:
        """A tournament's page (the id is read from the URL by its script, which says when there is none)."""
        known = tournament_known is None or await asyncio.to_thread(tournament_known, tournament_id)
        return HTMLResponse(_static("tournament.html"), status_code=200 if known else 404, headers=NO_CACHE)

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
        return _viser_page(viewer_page_with(REPLAY_VIEWER_SCRIPT), request)

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
