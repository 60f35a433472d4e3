"""The race server application: :func:`create_app` builds the FastAPI app, its lifespan starts what races share.

Run it with ``karting serve`` (one uvicorn worker: races live in this process's memory).
"""

from __future__ import annotations

import asyncio
import gc
import logging
import sys
from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import Any

from fastapi import APIRouter, FastAPI
from fastapi.openapi.docs import get_redoc_html
from fastapi.responses import HTMLResponse
from fastapi_offline import FastAPIOffline

from controllers.registry import REGISTRY, ControllerSpec
from server.db import RaceDatabase
from server.edge import install_edge
from server.hosts import ControllerHosts
from server.live import LiveRaces
from server.log_redaction import install_token_redaction
from server.loop import make_ordinary, make_realtime
from server.openapi_doc import truthful_openapi
from server.planning import PlannerPool
from server.race_config import HUMAN
from server.replays import RecordedRace, RecordedRaces, ReplayScenes, ReplayView, StoredReplays
from server.routes import api_router
from server.routes.catalogue import load_track, track_names
from server.scenario_runs import ScenarioRunner, ScenarioRunStore
from server.services import RaceServices, SceneFactory
from server.settings import Settings, is_loopback
from server.tournament_db import TournamentDatabase
from server.tournament_plots import TournamentPlots
from server.tournaments import TournamentRunner
from server.views import page_url
from server.warmup import warm_tick_path

log = logging.getLogger(__name__)

DESCRIPTION = """Head-to-head kart races between registered controllers and people, at 50 Hz.

* REST under `/api` (this page).
* Websockets: `/api/races/{id}/drive?kart=K&token=T` (drive a human kart) and `/api/races/{id}/telemetry`
  (the race's frames at about 25 Hz); their messages are described in `server/routes/drive.py` and
  `server/routes/telemetry.py`.
* The 3D view of a race: `/races/{id}/viewer/` while it is live, its replay player `/races/{id}/replay/` once it
  is over (the race's `viewer_url` says which); its page: `/races/{id}`.
"""


def _scene_factory(settings: Settings) -> SceneFactory | None:
    if not settings.viewer_enabled:
        return None
    try:
        from web.scene import RaceScene
    except ImportError as exc:
        log.warning("no 3D view: web.scene is not available (%s)", exc)
        return None
    return RaceScene


ReplayFactory = Callable[[RecordedRace], ReplayView]


def _replay_factory(settings: Settings) -> ReplayFactory | None:
    if not settings.viewer_enabled:
        return None
    try:
        from web.replay_scene import ReplayScene
    except ImportError as exc:
        log.warning("no replay player: web.replay_scene is not available (%s)", exc)
        return None

    def open_replay(recorded: RecordedRace) -> ReplayView:
        race = recorded.race
        karts = [(kart.name, kart.controller) for kart in race.karts]
        label = f"{race.track} · replay of race {race.id}"
        return ReplayScene(recorded.track, karts, label, recorded.frames(), page_url(race.id))

    return open_replay


def _replay_scenes(recorded: RecordedRaces, settings: Settings) -> ReplayScenes:
    """The replay scenes, started (without 3D views, none ever opens)."""
    factory = _replay_factory(settings)

    def open_view(race_id: str) -> ReplayView | None:
        loaded = recorded.load(race_id) if factory is not None else None
        return factory(loaded) if factory is not None and loaded is not None else None

    scenes = ReplayScenes(open_view, settings.max_replays, settings.replay_idle_s)
    scenes.start()
    return scenes


def _web_router(
    races: Callable[[], LiveRaces], replays: StoredReplays, tournaments: Callable[[], TournamentRunner]
) -> APIRouter | None:
    try:
        from web.routes import RaceState, make_web_router
    except ImportError as exc:
        log.warning("no web pages: web.routes is not available (%s)", exc)
        return None

    def race_state(race_id: str) -> RaceState | None:
        status = races().status(race_id)
        return RaceState(status.value, not status.live) if status is not None else None

    def tournament_known(tournament_id: str) -> bool:
        return tournaments().store.exists(tournament_id)

    router: APIRouter = make_web_router(
        lambda race_id: races().scene_port(race_id), race_state, replays, tournament_known
    )
    return router


DOCS_ASSETS = "/docs-assets"  # where fastapi-offline serves Swagger UI's and ReDoc's files
# ReDoc's sidebar always shows its maker's logo from a CDN (an <img>): the page forbids outside images, so it
# makes no request off the server (the logo hides itself when it fails to load)
REDOC_POLICY = "img-src 'self' data:"


def _add_redoc(app: FastAPI) -> None:
    """``GET /redoc``: ReDoc from the fastapi-offline wheel, with no request leaving the server."""

    @app.get("/redoc", include_in_schema=False)
    def redoc() -> HTMLResponse:
        page = get_redoc_html(
            openapi_url=app.openapi_url or "/openapi.json",
            title=f"{app.title} - ReDoc",
            redoc_js_url=f"{DOCS_ASSETS}/redoc.standalone.js",
            redoc_favicon_url="data:,",
            with_google_fonts=False,
        )
        page.headers["Content-Security-Policy"] = REDOC_POLICY
        return page


def _offline_docs_app(lifespan: Callable[[FastAPI], AbstractAsyncContextManager[None]]) -> FastAPI:
    """The bare app, with /docs and /redoc (Swagger UI and ReDoc served from the fastapi-offline wheel: they
    work with no internet)."""
    app = FastAPIOffline(
        title="HeadToHead Karting",
        description=DESCRIPTION,
        version="0.1.0",
        lifespan=lifespan,
        static_url=DOCS_ASSETS,
        favicon_url="data:,",
        redoc_url=None,
    )
    _add_redoc(app)
    return app


def _tune_scheduling(settings: Settings) -> float:
    """Real-time priority (when asked for and allowed) and the GIL switch interval; returns the previous
    interval."""
    switch_interval = sys.getswitchinterval()
    if settings.realtime_priority:
        if make_realtime(settings.realtime_priority):
            log.info("the server runs at SCHED_FIFO priority %d", settings.realtime_priority)
        else:
            log.warning("real-time priority not allowed here (needs CAP_SYS_NICE); running as usual")
    # the event loop waits at most about this long for a busy thread to give up the GIL
    sys.setswitchinterval(settings.switch_interval_s)
    return switch_interval


def create_app(settings: Settings | None = None, *, controllers: Mapping[str, ControllerSpec] | None = None) -> FastAPI:
    """The race server. ``controllers`` replaces the public registry (tests add faulty drivers this way)."""
    settings = settings or Settings()
    catalogue = dict(REGISTRY if controllers is None else controllers)
    if HUMAN in catalogue:
        raise ValueError(f"{HUMAN!r} is reserved for human karts")
    scene_factory = _scene_factory(settings)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        install_token_redaction()  # after the server configured its logging
        switch_interval = _tune_scheduling(settings)
        db = await asyncio.to_thread(RaceDatabase, settings.database_url)
        aborted = await asyncio.to_thread(db.abort_unfinished)
        if aborted:
            log.warning("%d race(s) left running by a previous server marked aborted", aborted)
        pool = PlannerPool(settings.plan_workers)
        hosts = ControllerHosts(settings.controller_hosts) if settings.controller_hosts else None
        races = LiveRaces(RaceServices(settings, catalogue, pool, hosts, db, scene_factory))
        app.state.races = races
        app.state.recorded = recorded = RecordedRaces(db, load_track)
        app.state.replay_scenes = replay_scenes = _replay_scenes(recorded, settings)
        tournaments = await asyncio.to_thread(
            lambda: TournamentRunner(TournamentDatabase(db), settings.tournament_workers, settings.max_tournaments)
        )
        app.state.tournaments = tournaments
        app.state.scenario_runs = await asyncio.to_thread(
            lambda: ScenarioRunner(ScenarioRunStore(db), settings.tournament_workers)
        )
        # trackers run in this process only without hosts; only the public registry's are known safe to try here
        in_process = [s for name, s in catalogue.items() if hosts is None and REGISTRY.get(name) is s]
        try:
            await asyncio.gather(pool.wait_warm(), asyncio.to_thread(warm_tick_path, in_process))
            # what start-up built (modules, compiled kernels, tables) lives as long as the process: keep it out
            # of the collector's full passes, which would otherwise stall the ticks for tens of milliseconds
            gc.collect()
            gc.freeze()
            yield
        finally:
            await races.shutdown()
            await replay_scenes.shutdown()
            await asyncio.to_thread(tournaments.shutdown)
            await asyncio.to_thread(app.state.scenario_runs.shutdown)
            await asyncio.to_thread(pool.shutdown)
            if hosts is not None:
                await asyncio.to_thread(hosts.close)
            db.close()
            sys.setswitchinterval(switch_interval)
            make_ordinary()

    app = _offline_docs_app(lifespan)
    app.state.settings = settings
    install_edge(app, settings)
    truthful_openapi(app, settings, catalogue, track_names)
    app.state.tournament_plots = TournamentPlots()
    app.include_router(api_router)
    replays = StoredReplays(lambda: app.state.races, lambda: app.state.replay_scenes)
    web = _web_router(lambda: app.state.races, replays, lambda: app.state.tournaments)
    if web is not None:
        app.include_router(web)
    return app


def connection_options(settings: Settings) -> dict[str, Any]:
    """uvicorn's connection limits from ``settings``: idle keep-alive connections and unanswered websocket pings
    time out, and no websocket message over ``ws_max_message_bytes`` is assembled (each socket has a smaller
    limit of its own, :mod:`server.routes.sockets`)."""
    return {
        "timeout_keep_alive": settings.keep_alive_timeout_s,
        "ws_ping_interval": settings.ws_ping_interval_s,
        "ws_ping_timeout": settings.ws_ping_timeout_s,
        "ws_max_size": settings.ws_max_message_bytes,
    }


def serve(settings: Settings) -> None:
    """Run the server with uvicorn until interrupted: one worker (races live in this process), no websocket
    compression (viewer frames are already compressed), timers to the microsecond (:mod:`server.loop`)."""
    import uvicorn

    shown = "localhost" if settings.host in ("127.0.0.1", "0.0.0.0", "::") else settings.host
    print(f"HeadToHead Karting server: open http://{shown}:{settings.port}/ (API docs at /docs)", flush=True)
    if not is_loopback(settings.host) and (settings.allowed_hosts is None or settings.api_key is None):
        print("exposed: set KARTING_ALLOWED_HOSTS and KARTING_API_KEY (README: Exposed deployment)", flush=True)
    uvicorn.run(
        create_app(settings),
        host=settings.host,
        port=settings.port,
        workers=1,
        ws_per_message_deflate=False,
        loop="server.loop:new_precise_loop",
        log_level="info",
        **connection_options(settings),
    )
