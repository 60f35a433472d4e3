"""REST routes under ``/api``: tracks, controllers, races (create, list, inspect, stop), results and replays.

Live races are answered from memory, older ones from the database, so a restarted server still serves every
finished race.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from functools import lru_cache
from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException, status
from fastapi.exceptions import RequestValidationError
from fastapi.requests import HTTPConnection
from fastapi.responses import JSONResponse

from controllers.registry import ControllerSpec
from server.db import StoredRace
from server.drivers import HUMAN
from server.live import LiveRaces, TooManyRacesError
from server.models import (
    ControllerOut,
    CreatedKartOut,
    DriverStatusOut,
    KartOut,
    RaceCreatedOut,
    RaceDetailOut,
    RaceIn,
    RaceSummaryOut,
    ResultOut,
    StandingOut,
    TicksOut,
    TickStatsOut,
    TrackOut,
)
from server.session import KartEntry, RaceConfig, RaceSession
from sim_core.params import DT
from sim_core.track import Track
from sim_core.track_io import builtin_track_names, get_track

HUMAN_DESCRIPTION = "A person (or a client program) driving over the websocket /api/races/{id}/drive."
LIST_LIMIT = 200


def get_races(connection: HTTPConnection) -> LiveRaces:
    """The app's :class:`LiveRaces` (set up in the lifespan)."""
    races: LiveRaces = connection.app.state.races
    return races


Races = Annotated[LiveRaces, Depends(get_races)]

router = APIRouter(prefix="/api")


# ----------------------------------------------------------------------------------------- tracks, controllers
def track_names() -> list[str]:
    """Every built-in track, each also driven the other way."""
    names = builtin_track_names()
    return [*names, *(f"{name}-reversed" for name in names)]


@lru_cache(maxsize=32)
def load_track(name: str) -> Track:
    """A built-in track by name (cached: tracks are never changed)."""
    return get_track(name)


@router.get("/tracks", response_model=list[TrackOut])
async def list_tracks() -> list[TrackOut]:
    """The built-in tracks (each also as ``NAME-reversed``)."""
    tracks = await asyncio.to_thread(lambda: [load_track(n) for n in track_names()])
    return [
        TrackOut(
            name=t.name,
            length_m=round(t.length, 1),
            laps=t.laps,
            n_checkpoints=t.n_checkpoints,
            n_lanes=t.n_lanes,
            lane_change_limit=t.lane_change_limit,
            description=t.description,
        )
        for t in tracks
    ]


@router.get("/controllers", response_model=list[ControllerOut])
async def list_controllers(races: Races) -> list[ControllerOut]:
    """Every registered controller, plus ``human``."""
    specs = [races.catalogue[name] for name in sorted(races.catalogue)]
    out = [ControllerOut(name=s.name, description=s.description, parameters=dict(s.parameters)) for s in specs]
    return [*out, ControllerOut(name=HUMAN, description=HUMAN_DESCRIPTION, parameters={})]


# ----------------------------------------------------------------------------------------- races
def race_config(body: RaceIn, catalogue: Mapping[str, ControllerSpec], max_laps: int) -> RaceConfig:
    """Check a race request against the tracks and controllers; every problem becomes one 422 entry."""
    errors: list[dict[str, Any]] = []

    def problem(loc: tuple[str | int, ...], msg: str, value: Any) -> None:
        errors.append({"type": "value_error", "loc": ("body", *loc), "msg": msg, "input": value})

    track = None
    if body.track in track_names():
        track = load_track(body.track)
    else:
        problem(("track",), f"unknown track {body.track!r}; known: {track_names()}", body.track)
    if body.laps is not None and body.laps > max_laps:
        problem(("laps",), f"laps must be in 1..{max_laps}, got {body.laps}", body.laps)
    known = [*sorted(catalogue), HUMAN]
    for i, kart in enumerate(body.karts):
        if kart.controller not in known:
            msg = f"unknown controller {kart.controller!r}; known: {known}"
            problem(("karts", i, "controller"), msg, kart.controller)
    if body.start_lanes is not None:
        if len(body.start_lanes) != len(body.karts):
            problem(
                ("start_lanes",),
                f"give one start lane per kart: {len(body.karts)} karts, {len(body.start_lanes)} lanes",
                body.start_lanes,
            )
        n_lanes = track.n_lanes if track is not None else 4
        for j, lane in enumerate(body.start_lanes):
            if not 1 <= lane <= n_lanes:
                problem(("start_lanes", j), f"lanes are 1..{n_lanes}, got {lane}", lane)
    if errors or track is None:
        raise RequestValidationError(errors)
    karts = tuple(
        KartEntry(kart.name or f"{kart.controller} #{i + 1}", kart.controller) for i, kart in enumerate(body.karts)
    )
    return RaceConfig(
        track_name=body.track,
        track=track,
        laps=body.laps if body.laps is not None else track.laps,
        seed=body.seed,
        start_lanes=tuple(body.start_lanes) if body.start_lanes is not None else None,
        kart_preset=body.kart_preset,
        karts=karts,
    )


def _viewer_url(races: LiveRaces, race_id: str) -> str | None:
    return f"/races/{race_id}/viewer/" if races.scene_factory is not None else None


@router.post(
    "/races",
    status_code=status.HTTP_201_CREATED,
    response_model=RaceCreatedOut,
    responses={422: {"description": "unknown track or controller, bad laps, lanes or seed, more than 8 karts"}},
)
async def create_race(body: RaceIn, races: Races) -> RaceCreatedOut:
    """Start a race. Human karts get a drive token (shown only in this answer) and a page to drive from."""
    config = race_config(body, races.catalogue, races.settings.max_laps)
    try:
        session = await races.create(config)
    except TooManyRacesError as exc:
        raise HTTPException(status.HTTP_429_TOO_MANY_REQUESTS, str(exc)) from None
    karts = []
    tokens: dict[str, str] = {}
    for d in session.drivers:
        drive_url = None
        if d.token is not None:
            tokens[str(d.index)] = d.token
            drive_url = f"/races/{session.id}/drive?kart={d.index}&token={d.token}"
        karts.append(CreatedKartOut(index=d.index, name=d.name, controller=d.controller_name, drive_url=drive_url))
    return RaceCreatedOut(
        id=session.id,
        status=session.status,
        track=config.track_name,
        laps=config.laps,
        seed=config.seed,
        kart_preset=config.kart_preset,
        karts=karts,
        viewer_url=_viewer_url(races, session.id),
        telemetry_url=f"/api/races/{session.id}/telemetry",
        drive_tokens=tokens,
    )


def _standings_live(session: RaceSession) -> list[StandingOut]:
    frame = session.frame
    if frame is None:
        return []
    return [
        StandingOut(
            position=k.position,
            index=k.index,
            name=k.name,
            controller=k.controller,
            lap=k.lap,
            checkpoints_passed=k.checkpoints_passed,
            finished=k.finished,
            finish_time=k.finish_time,
            controller_faults=k.controller_faults,
        )
        for k in sorted(frame.karts, key=lambda k: k.position)
    ]


def _standings_stored(race: StoredRace) -> list[StandingOut]:
    if race.result is None:
        return []
    return [
        StandingOut(
            position=k["position"],
            index=k["index"],
            name=k["name"],
            controller=k["controller"],
            lap=min(k["laps"] + 1, race.laps),
            checkpoints_passed=k["checkpoints_passed"],
            finished=k["finished"],
            finish_time=k["finish_time"],
            controller_faults=k["controller_faults"],
        )
        for k in sorted(race.result["karts"], key=lambda k: k["position"])
    ]


def _summary_live(session: RaceSession) -> RaceSummaryOut:
    frame = session.frame
    return RaceSummaryOut(
        id=session.id,
        status=session.status,  # type: ignore[arg-type]
        track=session.config.track_name,
        laps=session.config.laps,
        created_at=session.created_at,
        time=frame.time if frame is not None else 0.0,
        karts=[KartOut(**k) for k in session.kart_list()],
        standings=_standings_live(session),
        winner=session.result["winner"] if session.result is not None else None,
    )


def _summary_stored(race: StoredRace) -> RaceSummaryOut:
    return RaceSummaryOut(
        id=race.id,
        status=race.status,  # type: ignore[arg-type]
        track=race.track,
        laps=race.laps,
        created_at=race.created_at,
        time=race.duration or 0.0,
        karts=[KartOut(**k) for k in race.karts],
        standings=_standings_stored(race),
        winner=race.result["winner"] if race.result is not None else None,
    )


def _drivers_live(session: RaceSession) -> list[DriverStatusOut]:
    return [
        DriverStatusOut(
            index=d.index,
            name=d.name,
            controller=d.controller_name,
            controller_faults=d.faults,
            exceptions=d.exceptions,
            hangs=d.hangs,
            missed_deadlines=d.missed,
            planner_faults=d.planner_faults,
            plans_applied=d.plans_applied,
            disabled=d.disabled,
            braking=d.braking,
            driver_connected=d.connected if d.human else None,
            last_error=d.last_error,
        )
        for d in session.drivers
    ]


def _drivers_stored(race: StoredRace) -> list[DriverStatusOut]:
    by_index = {k["index"]: k for k in race.result["karts"]} if race.result is not None else {}
    out = []
    for kart in race.karts:
        k = by_index.get(kart["index"], {})
        out.append(
            DriverStatusOut(
                index=kart["index"],
                name=kart["name"],
                controller=kart["controller"],
                controller_faults=k.get("controller_faults", 0),
                exceptions=k.get("exceptions", 0),
                hangs=k.get("hangs", 0),
                missed_deadlines=k.get("missed_deadlines", 0),
                planner_faults=k.get("planner_faults", 0),
                plans_applied=k.get("plans_applied", 0),
                disabled=k.get("disabled", False),
                braking=False,
                driver_connected=False if kart["controller"] == HUMAN else None,
                last_error=k.get("last_error"),
            )
        )
    return out


def _detail(races: LiveRaces, summary: RaceSummaryOut, **fields: Any) -> RaceDetailOut:
    race_id = summary.id
    return RaceDetailOut(
        **summary.model_dump(),
        **fields,
        viewer_url=_viewer_url(races, race_id),
        telemetry_url=f"/api/races/{race_id}/telemetry",
        result_url=f"/api/races/{race_id}/result",
        replay_url=f"/api/races/{race_id}/replay",
    )


def _detail_live(races: LiveRaces, session: RaceSession) -> RaceDetailOut:
    stats = session.tick_stats()
    config = session.config
    return _detail(
        races,
        _summary_live(session),
        seed=config.seed,
        kart_preset=config.kart_preset,
        start_lanes=list(config.start_lanes) if config.start_lanes is not None else None,
        step=session.frame.step if session.frame is not None else 0,
        drivers=_drivers_live(session),
        tick_stats=TickStatsOut(**stats) if stats is not None else None,
        error=session.error,
    )


def _detail_stored(races: LiveRaces, race: StoredRace) -> RaceDetailOut:
    return _detail(
        races,
        _summary_stored(race),
        seed=race.seed,
        kart_preset=race.kart_preset,
        start_lanes=race.start_lanes,
        step=round((race.duration or 0.0) / DT),
        drivers=_drivers_stored(race),
        tick_stats=TickStatsOut(**race.tick_stats) if race.tick_stats else None,
        error=None,
    )


async def _stored_or_404(races: LiveRaces, race_id: str) -> StoredRace:
    race = await asyncio.to_thread(races.db.get, race_id)
    if race is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no race {race_id!r}")
    return race


@router.get("/races", response_model=list[RaceSummaryOut])
async def list_races(races: Races) -> list[RaceSummaryOut]:
    """Live and past races, newest first, with their standings."""
    stored = await asyncio.to_thread(races.db.list, LIST_LIMIT)
    out = {s.id: _summary_live(s) for s in races.sessions.values()}
    for race in stored:
        if race.id not in out:
            out[race.id] = _summary_stored(race)
    return sorted(out.values(), key=lambda r: r.created_at, reverse=True)


@router.get("/races/{race_id}", response_model=RaceDetailOut, responses={404: {"description": "no such race"}})
async def get_race(race_id: str, races: Races) -> RaceDetailOut:
    """One race: its settings, standings, drivers' faults and tick timing."""
    session = races.get(race_id)
    if session is not None:
        return _detail_live(races, session)
    return _detail_stored(races, await _stored_or_404(races, race_id))


@router.post(
    "/races/{race_id}/stop",
    response_model=RaceDetailOut,
    responses={404: {"description": "no such race"}, 409: {"description": "the race is already over"}},
)
async def stop_race(race_id: str, races: Races) -> RaceDetailOut:
    """End a live race now (status ``stopped``; its state so far is stored as its result)."""
    session = races.get(race_id)
    if session is None:
        race = await _stored_or_404(races, race_id)
        raise HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is already over ({race.status})")
    if not session.stop():
        raise HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is already over ({session.status})")
    await session.wait_status(("stopped", "finished", "aborted"))
    return _detail_live(races, session)


@router.get("/races/{race_id}/ticks", response_model=TicksOut, responses={404: {"description": "no such race"}})
async def race_ticks(race_id: str, races: Races) -> TicksOut:
    """Tick timing of a race with the raw jitter of its last 3,000 ticks (empty once it left memory)."""
    session = races.get(race_id)
    if session is not None:
        stats = session.tick_stats()
        recent = session.schedule.recent_jitter_ms() if session.schedule is not None else []
        return TicksOut(race_id=race_id, stats=TickStatsOut(**stats) if stats else None, recent_jitter_ms=recent)
    race = await _stored_or_404(races, race_id)
    stored = TickStatsOut(**race.tick_stats) if race.tick_stats else None
    return TicksOut(race_id=race_id, stats=stored, recent_jitter_ms=[])


def _not_over(race_id: str, race_status: str) -> HTTPException:
    return HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is {race_status}: no result yet")


@router.get(
    "/races/{race_id}/result",
    response_model=ResultOut,
    responses={404: {"description": "no such race"}, 409: {"description": "the race is not over (or was aborted)"}},
)
async def race_result(race_id: str, races: Races) -> ResultOut:
    """The referee's result per kart (once the race is over)."""
    session = races.get(race_id)
    if session is not None:
        if session.live or session.result is None:
            raise _not_over(race_id, session.status)
        return ResultOut(**session.result)
    race = await _stored_or_404(races, race_id)
    if race.result is None:
        raise _not_over(race_id, race.status)
    return ResultOut(**race.result)


@router.get(
    "/races/{race_id}/replay",
    responses={
        200: {
            "description": "{race_id, karts, track, dt, poses[step][kart] = [x, y, heading, speed, steer, "
            "throttle], plans: [{step, kart, plan}]} (the headless replay format)"
        },
        404: {"description": "no such race"},
        409: {"description": "the race is not over"},
    },
)
async def race_replay(race_id: str, races: Races) -> JSONResponse:
    """Every kart's pose and inputs per step and the plans as they were applied (once the race is over)."""
    session = races.get(race_id)
    if session is not None:
        if session.live:
            raise _not_over(race_id, session.status)
        return JSONResponse(await asyncio.to_thread(session.replay_dict))
    replay = await asyncio.to_thread(races.db.replay, race_id)
    if replay is None:
        race = await _stored_or_404(races, race_id)
        raise _not_over(race_id, race.status)
    return JSONResponse(replay)
