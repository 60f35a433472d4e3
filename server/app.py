"""The race server application: :func:`create_app` builds the FastAPI app, its lifespan starts what races share.

Run it with ``karting serve`` (one uvicorn worker: races live in this process's memory).
"""

from __future__ import annotations

import asyncio
import gc
import logging
import sys
from collections.abc import AsyncIterator, Callable, Mapping
from contextlib import asynccontextmanager
from typing import Any

from fastapi import APIRouter, FastAPI

from controllers.registry import REGISTRY, ControllerSpec
from server.db import RaceDatabase
from server.hosts import ControllerHosts
from server.live import LiveRaces
from server.loop import make_ordinary, make_realtime
from server.planning import PlannerPool
from server.race_config import HUMAN
from server.routes import api_router
from server.services import RaceServices, SceneFactory
from server.settings import Settings
from server.tournament_db import TournamentDatabase
from server.tournament_plots import TournamentPlots
from server.tournaments import TournamentRunner
from server.warmup import warm_tick_path

log = logging.getLogger(__name__)

DESCRIPTION = """Head-to-head kart races between registered controllers and people, at 50 Hz.

* REST under `/api` (this page).
* Websockets: `/api/races/{id}/drive?kart=K&token=T` (drive a human kart) and `/api/races/{id}/telemetry`
  (the race's frames at about 25 Hz); their messages are described in `server/routes/drive.py` and
  `server/routes/telemetry.py`.
* The 3D view of a race: `/races/{id}/viewer/`.
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


def _web_router(races: Callable[[], LiveRaces]) -> APIRouter | None:
    try:
        from web.routes import make_web_router
    except ImportError as exc:
        log.warning("no web pages: web.routes is not available (%s)", exc)
        return None
    router: APIRouter = make_web_router(lambda race_id: races().scene_port(race_id))
    return router


def create_app(settings: Settings | None = None, *, controllers: Mapping[str, ControllerSpec] | None = None) -> FastAPI:
    """The race server. ``controllers`` replaces the public registry (tests add faulty drivers this way)."""
    settings = settings or Settings()
    catalogue = dict(REGISTRY if controllers is None else controllers)
    if HUMAN in catalogue:
        raise ValueError(f"{HUMAN!r} is reserved for human karts")
    scene_factory = _scene_factory(settings)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        switch_interval = sys.getswitchinterval()
        if settings.realtime_priority:
            if make_realtime(settings.realtime_priority):
                log.info("the server runs at SCHED_FIFO priority %d", settings.realtime_priority)
            else:
                log.warning("real-time priority not allowed here (needs CAP_SYS_NICE); running as usual")
        # the event loop waits at most about this long for a busy thread to give up the GIL
        sys.setswitchinterval(settings.switch_interval_s)
        db = await asyncio.to_thread(RaceDatabase, settings.database_url)
        aborted = await asyncio.to_thread(db.abort_unfinished)
        if aborted:
            log.warning("%d race(s) left running by a previous server marked aborted", aborted)
        pool = PlannerPool(settings.plan_workers)
        hosts = ControllerHosts(settings.controller_hosts) if settings.controller_hosts else None
        races = LiveRaces(RaceServices(settings, catalogue, pool, hosts, db, scene_factory))
        app.state.races = races
        tournaments = await asyncio.to_thread(
            lambda: TournamentRunner(TournamentDatabase(db), settings.tournament_workers, settings.max_tournaments)
        )
        app.state.tournaments = tournaments
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
            await asyncio.to_thread(tournaments.shutdown)
            await asyncio.to_thread(pool.shutdown)
            if hosts is not None:
                await asyncio.to_thread(hosts.close)
            db.close()
            sys.setswitchinterval(switch_interval)
            make_ordinary()

    app = FastAPI(title="HeadToHead Karting", description=DESCRIPTION, version="0.1.0", lifespan=lifespan)
    app.state.settings = settings
    app.state.tournament_plots = TournamentPlots()
    app.include_router(api_router)
    web = _web_router(lambda: app.state.races)
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
