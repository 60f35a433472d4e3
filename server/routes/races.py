"""Races: create, list, inspect, stop; tick timing, results and replays.

Live races are answered from memory, older ones from the database, so a restarted server still serves every
finished race; either way through one snapshot (:mod:`server.snapshot`) and one view per resource
(:mod:`server.views`).
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any

from fastapi import APIRouter, HTTPException, status
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from controllers.registry import ControllerSpec
from server.controller_params import check_params
from server.db import StoredRace
from server.deps import API_KEY_RESPONSES, ApiKey, Races, Recorded
from server.limits import default_kart_name
from server.live import LiveRaces, TooManyRacesError
from server.models import ErrorOut, RaceCreatedOut, RaceDetailOut, RaceIn, RaceSummaryOut, ResultOut, TicksOut
from server.race_config import HUMAN, KartEntry, RaceConfig
from server.race_report import RaceReport
from server.routes.catalogue import load_track, track_names
from server.status import OVER_STATUSES, RaceStatus
from server.strict_json import StrictJSONRoute
from server.views import created_view, detail_view, result_view, summary_view, ticks_view

LIST_LIMIT = 200

router = APIRouter(route_class=StrictJSONRoute)


def kart_names(body: RaceIn) -> list[str]:
    """Each kart's display name: as given (trimmed), or the default (``controller N``)."""
    return [
        kart.name.strip() if kart.name else default_kart_name(kart.controller, i) for i, kart in enumerate(body.karts)
    ]


def _name_problems(names: list[str]) -> list[tuple[int, str]]:
    """(kart, what is wrong) for blank names and names given twice (compared without case)."""
    out = []
    for i, name in enumerate(names):
        first = next(j for j, other in enumerate(names) if other.casefold() == name.casefold())
        if not name:
            out.append((i, "a kart's name must not be blank"))
        elif first != i:
            out.append((i, f"kart {first + 1} is already called {names[first]!r}: give each kart its own name"))
    return out


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
        elif kart.controller == HUMAN and kart.params:
            problem(("karts", i, "params"), "human karts take no parameters", kart.params)
        elif kart.controller != HUMAN:
            for p in check_params(catalogue[kart.controller], kart.params):
                problem(("karts", i, "params", p.name), p.message, kart.params[p.name])
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
    names = kart_names(body)
    for i, msg in _name_problems(names):
        problem(("karts", i, "name"), msg, body.karts[i].name)
    if errors or track is None:
        raise RequestValidationError(errors)
    karts = tuple(
        KartEntry(i, names[i], kart.controller, dict(kart.params), kart.pace, kart.team)
        for i, kart in enumerate(body.karts)
    )
    return RaceConfig(
        track_name=body.track,
        track=track,
        laps=body.laps if body.laps is not None else track.laps,
        seed=body.seed,
        start_lanes=tuple(body.start_lanes) if body.start_lanes is not None else None,
        kart_preset=body.kart_preset,
        karts=karts,
        conditions=body.conditions,
    )


def _viewer(races: LiveRaces) -> bool:
    """Whether this server opens a 3D view for its races."""
    return races.services.scene_factory is not None


def _viewer_open(races: LiveRaces, race_id: str) -> bool:
    """Whether the race's live 3D view is open now (it closes ``keep_finished_s`` after the race ends)."""
    return races.scene_port(race_id) is not None


async def _stored_or_404(races: LiveRaces, race_id: str) -> StoredRace:
    race = await asyncio.to_thread(races.services.db.get, race_id)
    if race is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no race {race_id!r}")
    return race


def _not_over(race_id: str, race_status: RaceStatus) -> HTTPException:
    return HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is {race_status.value}: no result yet")


@router.post(
    "/races",
    status_code=status.HTTP_201_CREATED,
    response_model=RaceCreatedOut,
    dependencies=[ApiKey],
    responses={
        **API_KEY_RESPONSES,
        422: {
            "description": "unknown track, controller or controller parameter, bad laps, lanes, seed or parameter "
            "value, too many karts, a kart name too long or given twice (limits: GET /api/limits); a body that is "
            "not strict JSON"
        },
        429: {"model": ErrorOut, "description": "the server runs its most races at once (max_sessions)"},
    },
)
async def create_race(body: RaceIn, races: Races) -> RaceCreatedOut:
    """Start a race. Human karts get a drive token (shown only in this answer) and a page to drive from."""
    config = race_config(body, races.services.catalogue, races.settings.max_laps)
    try:
        session = await races.create(config)
    except TooManyRacesError as exc:
        raise HTTPException(status.HTTP_429_TOO_MANY_REQUESTS, str(exc)) from None
    tokens = {d.index: d.token for d in session.drivers if d.token is not None}
    return created_view(session.snapshot(ticks=False), tokens, _viewer(races))


@router.get("/races", response_model=list[RaceSummaryOut])
async def list_races(races: Races) -> list[RaceSummaryOut]:
    """Live and past races, newest first, with their standings."""
    stored = await asyncio.to_thread(races.services.db.list, LIST_LIMIT)
    out = {s.id: summary_view(s.snapshot(ticks=False)) for s in races.sessions.values()}
    for race in stored:
        if race.id not in out:
            out[race.id] = summary_view(race.snapshot())
    return sorted(out.values(), key=lambda r: r.created_at, reverse=True)


@router.get("/races/{race_id}", response_model=RaceDetailOut, responses={404: {"description": "no such race"}})
async def get_race(race_id: str, races: Races) -> RaceDetailOut:
    """One race: its settings, standings, drivers' faults and tick timing."""
    session = races.get(race_id)
    snapshot = session.snapshot() if session is not None else (await _stored_or_404(races, race_id)).snapshot()
    return detail_view(snapshot, _viewer(races), _viewer_open(races, race_id))


@router.post(
    "/races/{race_id}/stop",
    response_model=RaceDetailOut,
    dependencies=[ApiKey],
    responses={
        **API_KEY_RESPONSES,
        404: {"description": "no such race"},
        409: {"description": "the race is already over"},
    },
)
async def stop_race(race_id: str, races: Races) -> RaceDetailOut:
    """End a live race now (status ``stopped``; its state so far is stored as its result)."""
    session = races.get(race_id)
    if session is None:
        race = await _stored_or_404(races, race_id)
        raise HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is already over ({race.status.value})")
    if not session.stop():
        raise HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is already over ({session.status.value})")
    await session.wait_status(OVER_STATUSES)
    return detail_view(session.snapshot(), _viewer(races), _viewer_open(races, race_id))


@router.get("/races/{race_id}/ticks", response_model=TicksOut, responses={404: {"description": "no such race"}})
async def race_ticks(race_id: str, races: Races) -> TicksOut:
    """Tick timing of a race with the raw jitter of its last 3,000 ticks (empty once it left memory)."""
    session = races.get(race_id)
    if session is not None:
        recent = session.schedule.recent_jitter_ms() if session.schedule is not None else []
        return ticks_view(race_id, session.tick_stats(), recent)
    return ticks_view(race_id, (await _stored_or_404(races, race_id)).tick_stats, [])


@router.get(
    "/races/{race_id}/result",
    response_model=ResultOut,
    responses={404: {"description": "no such race"}, 409: {"description": "the race is not over (or was aborted)"}},
)
async def race_result(race_id: str, races: Races) -> ResultOut:
    """The referee's result per kart (once the race is over)."""
    session = races.get(race_id)
    if session is not None:
        result, race_status = (None if session.live else session.result), session.status
    else:
        stored = await _stored_or_404(races, race_id)
        result, race_status = stored.result, stored.status
    if result is None:
        raise _not_over(race_id, race_status)
    return result_view(result)


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
        return JSONResponse(await asyncio.to_thread(session.replay_json))
    replay = await asyncio.to_thread(races.services.db.replay, race_id)
    if replay is None:
        race = await _stored_or_404(races, race_id)
        raise _not_over(race_id, race.status)
    return JSONResponse(replay)


@router.get(
    "/races/{race_id}/report",
    response_model=RaceReport,
    responses={
        404: {"description": "no such race"},
        409: {"description": "the race is not over, or left no replay to derive the figures from"},
    },
)
async def get_race_report(race_id: str, races: Races, recorded: Recorded) -> RaceReport:
    """The figures of the race's page, re-simulated from its replay: lap and sector times, gaps, positions by
    lap, speed along the lap, tyre wear and the incidents with their times."""
    session = races.get(race_id)
    if session is not None and (session.live or session.result is None):
        raise _not_over(race_id, session.status)
    loaded = await asyncio.to_thread(recorded.load, race_id)
    if loaded is None:
        race = await _stored_or_404(races, race_id)
        raise HTTPException(status.HTTP_409_CONFLICT, f"race {race_id} is {race.status.value}: no replay to analyse")
    return await asyncio.to_thread(loaded.report)
