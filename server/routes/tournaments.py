"""Tournaments: start one (``POST /api/tournaments``), follow its progress and read its results
(``GET /api/tournaments/{id}``), its statistics (``GET /api/tournaments/{id}/stats``, the stats JSON of the
README), list them, stop one. Its races are ordinary stored races: ``/api/races/{race_id}`` (result, replay).
"""

from __future__ import annotations

import asyncio
from datetime import datetime
from typing import Any

from fastapi import APIRouter, HTTPException, status
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ConfigDict, Field

from arena.stats import tournament_stats
from arena.tournament import TournamentSpec
from server.deps import Tournaments
from server.models import MAX_SEED
from server.tournament_db import TOURNAMENT_ID, StoredTournament, TournamentRace
from server.tournaments import TooManyTournamentsError, TournamentConflictError, TournamentRunner

router = APIRouter()
MAX_RACES_PER_PAIR = 500


class TournamentIn(BaseModel):
    """A new round-robin tournament (or the resumption of a stopped one: the same ``id`` and settings)."""

    model_config = ConfigDict(extra="forbid")

    agents: list[str] = Field(min_length=2, max_length=12, description="names from GET /api/controllers")
    tracks: list[str] = Field(default=["oval", "complex"], min_length=1, max_length=8)
    races_per_pair: int = Field(default=50, ge=1, le=MAX_RACES_PER_PAIR, description="per pair and track")
    seed: int = Field(default=0, ge=0, le=MAX_SEED)
    laps: int | None = Field(default=None, ge=1, le=20, description="default: each track's")
    time_limit: float | None = Field(default=None, gt=0.0, le=3600.0, description="[s] default: the rules'")
    kart_preset: str = Field(default="paper", pattern="^(paper|original)$")
    id: str | None = Field(default=None, pattern=TOURNAMENT_ID.pattern, description="default: a new id")


class TournamentRaceOut(BaseModel):
    """One stored race of a tournament, with links to its result and replay."""

    index: int
    race_id: str
    track: str
    agents: list[str]
    start_lanes: list[int]
    seed: int
    winner: str | None
    duration: float
    wall_seconds: float
    url: str
    result_url: str
    replay_url: str


class TournamentOut(BaseModel):
    """A tournament: settings, progress, its races so far and (once it has races) its statistics."""

    id: str
    created_at: datetime
    status: str = Field(description="running, finished, stopped or failed")
    running: bool = Field(description="running in this server process now")
    done: int
    total: int
    progress: float = Field(description="done / total")
    spec: dict[str, Any]
    error: str | None
    url: str
    stats_url: str
    races: list[TournamentRaceOut] | None = Field(None, description="only in GET /api/tournaments/{id}")
    stats: dict[str, Any] | None = Field(None, description="the stats JSON over the races so far (see the README)")


def _spec(body: TournamentIn) -> TournamentSpec:
    spec = TournamentSpec(
        tuple(body.agents),
        tuple(body.tracks),
        body.races_per_pair,
        body.seed,
        body.laps,
        body.time_limit,
        body.kart_preset,
    )
    problems = spec.problems()
    if problems:
        raise RequestValidationError(
            [
                {"type": "value_error", "loc": ("body", name), "msg": message, "input": getattr(body, name)}
                for name, message in problems.items()
            ]
        )
    return spec


def _race_view(race: TournamentRace) -> TournamentRaceOut:
    winner = race.record.winner
    return TournamentRaceOut(
        index=race.job.index,
        race_id=race.race_id,
        track=race.job.track,
        agents=list(race.job.agents),
        start_lanes=list(race.job.start_lanes),
        seed=race.job.seed,
        winner=race.job.agents[winner] if winner is not None else None,
        duration=race.record.duration,
        wall_seconds=race.wall_seconds,
        url=f"/api/races/{race.race_id}",
        result_url=f"/api/races/{race.race_id}/result",
        replay_url=f"/api/races/{race.race_id}/replay",
    )


def _view(
    stored: StoredTournament, running: bool, races: list[TournamentRace] | None = None, with_stats: bool = False
) -> TournamentOut:
    stats = None
    if with_stats and races:
        stats = tournament_stats([r.figures() for r in races]).to_json()
    return TournamentOut(
        id=stored.id,
        created_at=stored.created_at,
        status=stored.status.value,
        running=running,
        done=stored.done,
        total=stored.total,
        progress=stored.done / stored.total if stored.total else 0.0,
        spec=stored.spec.to_json(),
        error=stored.error,
        url=f"/api/tournaments/{stored.id}",
        stats_url=f"/api/tournaments/{stored.id}/stats",
        races=[_race_view(r) for r in races] if races is not None else None,
        stats=stats,
    )


async def _stored_or_404(runner: TournamentRunner, tournament_id: str) -> StoredTournament:
    stored = await asyncio.to_thread(runner.store.get, tournament_id)
    if stored is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no tournament {tournament_id!r}")
    return stored


@router.post(
    "/tournaments",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=TournamentOut,
    responses={
        409: {"description": "the id is running, or taken by other settings"},
        422: {"description": "unknown agents or tracks, bad numbers"},
        429: {"description": "too many tournaments running"},
    },
)
async def start_tournament(body: TournamentIn, tournaments: Tournaments) -> TournamentOut:
    """Start a round robin (runs in the background: follow ``url``); an existing id with the same settings
    resumes it."""
    spec = _spec(body)
    try:
        stored = await asyncio.to_thread(tournaments.start, spec, body.id)
    except TournamentConflictError as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from None
    except TooManyTournamentsError as exc:
        raise HTTPException(status.HTTP_429_TOO_MANY_REQUESTS, str(exc)) from None
    return _view(stored, True)


@router.get("/tournaments", response_model=list[TournamentOut])
async def list_tournaments(tournaments: Tournaments) -> list[TournamentOut]:
    """Stored tournaments, newest first, with their progress."""
    stored = await asyncio.to_thread(tournaments.store.list)
    return [_view(t, tournaments.running(t.id)) for t in stored]


@router.get(
    "/tournaments/{tournament_id}", response_model=TournamentOut, responses={404: {"description": "no such tournament"}}
)
async def get_tournament(tournament_id: str, tournaments: Tournaments) -> TournamentOut:
    """A tournament's live progress, its races so far (linked to their results and replays) and statistics."""
    stored = await _stored_or_404(tournaments, tournament_id)
    races = await asyncio.to_thread(tournaments.store.races, tournament_id)
    view = await asyncio.to_thread(_view, stored, tournaments.running(tournament_id), races, True)
    return view


@router.get(
    "/tournaments/{tournament_id}/stats",
    responses={404: {"description": "no such tournament"}, 409: {"description": "no finished race yet"}},
)
async def tournament_statistics(tournament_id: str, tournaments: Tournaments) -> dict[str, Any]:
    """The stats JSON (``{"tracks": {TRACK: T, "combined": T}}``, see the README) over the races so far."""
    await _stored_or_404(tournaments, tournament_id)
    figures = await asyncio.to_thread(tournaments.store.figures, tournament_id)
    if not figures:
        raise HTTPException(status.HTTP_409_CONFLICT, f"tournament {tournament_id} has no finished race yet")
    return await asyncio.to_thread(lambda: tournament_stats(figures).to_json())


@router.post(
    "/tournaments/{tournament_id}/stop",
    response_model=TournamentOut,
    responses={404: {"description": "no such tournament"}, 409: {"description": "not running here"}},
)
async def stop_tournament(tournament_id: str, tournaments: Tournaments) -> TournamentOut:
    """Stop a running tournament after the races in flight (``stopped``; POST it again to resume)."""
    await _stored_or_404(tournaments, tournament_id)
    if not await asyncio.to_thread(tournaments.stop, tournament_id, 60.0):
        raise HTTPException(status.HTTP_409_CONFLICT, f"tournament {tournament_id} is not running")
    return _view(await _stored_or_404(tournaments, tournament_id), tournaments.running(tournament_id))
