"""Tournaments: start one (``POST /api/tournaments``), follow its progress and read its results
(``GET /api/tournaments/{id}``), its statistics (``GET /api/tournaments/{id}/stats``, the stats JSON of the
README), its report tables and plots for the pages (``GET /api/tournaments/{id}/tables``,
``GET /api/tournaments/{id}/plots/{name}.png``), list them, stop one, and rank the agents across every stored
tournament (``GET /api/tournaments/leaderboard``). Its races are ordinary stored races: ``/api/races/{race_id}``
(result, replay).
"""

from __future__ import annotations

import asyncio
from datetime import datetime
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Response, status
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, field_validator

from arena.records import RaceFigures
from arena.report import (
    METRIC_TITLES,
    pair_rows,
    plan_rows,
    plot_stems,
    rating_rows,
    safety_rows,
    start_lane_rows,
    win_rows,
)
from arena.stats import COMBINED, Standing, leaderboard, tournament_stats
from arena.tournament import MAX_TEAM_SIZE, TournamentSpec
from server.deps import API_KEY_RESPONSES, ApiKey, TournamentPlotsDep, Tournaments
from server.limits import MAX_SEED
from server.models import ErrorOut, JsonInt, ManifestOut, Name, not_a_bool
from server.strict_json import StrictJSONRoute
from server.tournament_db import TOURNAMENT_ID, StoredTournament, TournamentRace
from server.tournaments import TooManyTournamentsError, TournamentConflictError, TournamentRunner
from sim_core.conditions import ConditionName

router = APIRouter(route_class=StrictJSONRoute)
MAX_RACES_PER_PAIR = 500
RESERVED_IDS = frozenset({"leaderboard"})  # GET /api/tournaments/leaderboard is the leaderboard
MAX_LEADERBOARD_TOURNAMENTS = 10_000


class TournamentIn(BaseModel):
    """A new round-robin tournament (or the resumption of a stopped one: the same ``id`` and settings)."""

    model_config = ConfigDict(extra="forbid")

    agents: list[Name] = Field(
        min_length=2,
        max_length=12,
        description="names from GET /api/controllers, each optionally with parameters: NAME:KEY=VALUE:...",
    )
    tracks: list[Name] = Field(default=["oval", "complex"], min_length=1, max_length=8)
    races_per_pair: JsonInt = Field(default=50, ge=1, le=MAX_RACES_PER_PAIR, description="per pair and track")
    seed: JsonInt = Field(default=0, ge=0, le=MAX_SEED)
    laps: Annotated[int, Field(ge=1, le=20), BeforeValidator(not_a_bool)] | None = Field(
        default=None, description="default: each track's"
    )
    time_limit: Annotated[float, Field(gt=0.0, le=3600.0), BeforeValidator(not_a_bool)] | None = Field(
        default=None, description="[s] default: the rules'"
    )
    kart_preset: str = Field(default="paper", pattern="^(paper|original)$")
    conditions: ConditionName = Field(
        default="varied",
        description="race conditions drawn from each race's seed: varied (launch reactions, start wear, the "
        "drivers' imprecision), varied-pace (varied, each kart's pace within 2% of the kart's), "
        "varied-equal-distance (varied, every kart finishes after the same distance from its grid slot) or paper "
        "(the original's experiment)",
    )
    team_size: JsonInt = Field(
        default=1,
        ge=1,
        le=MAX_TEAM_SIZE,
        description="karts per agent in a race: 1 head to head, 2 team races (two karts of each agent on one row, "
        "in mirrored pairs of races: races_per_pair must be even)",
    )
    id: str | None = Field(default=None, pattern=TOURNAMENT_ID.pattern, description="default: a new id")

    @field_validator("id")
    @classmethod
    def _not_reserved(cls, value: str | None) -> str | None:
        if value in RESERVED_IDS:
            raise ValueError(f"{value!r} is reserved (the leaderboard's address)")
        return value


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
    manifest: ManifestOut | None = Field(
        None, description="what it measures: commit, agents with every parameter, kart, conditions (None: older)"
    )
    error: str | None
    url: str
    stats_url: str
    races: list[TournamentRaceOut] | None = Field(None, description="only in GET /api/tournaments/{id}")
    stats: dict[str, Any] | None = Field(None, description="the stats JSON over the races so far (see the README)")


class StandingOut(BaseModel):
    """One agent's line of the leaderboard."""

    agent: str
    tournaments: int = Field(description="stored tournaments it raced in")
    races: int
    wins: int
    win_rate: float = Field(description="wins / races")
    finished: int = Field(description="races it completed every lap of")
    safety_score_mean: float = Field(description="collisions at fault + illegal lane changes per race")
    safety_score_std: float = Field(description="population std. dev. (ddof=0), as the paper's tables")


class LeaderboardOut(BaseModel):
    """Every agent's standing over the races of every stored tournament (running ones: their races so far)."""

    tournaments: int = Field(description="stored tournaments with at least one race")
    races: int
    agents: list[StandingOut] = Field(description="best first: win rate, then wins, then lower safety score")


class TrackTablesOut(BaseModel):
    """The report's tables of one track (or ``combined``), rows of strings with a header row first, as
    :mod:`arena.report` writes them (``*``: significant at p = 0.05)."""

    wins: list[list[str]] = Field(description="row agent's wins against each column agent")
    safety: list[list[str]]
    plan: list[list[str]]
    start_lanes: list[list[str]] = Field(
        description="per pair, the row pair's first agent's wins–losses from each start lane and Fisher's exact test"
        " of the lane's effect; a last row for whichever kart started in each lane"
    )
    pairs: list[list[str]] = Field(
        description="per pair: races, the first agent's win rate with its 95% Wilson interval, distinct outcomes, "
        "wins from each start lane and the lane's test"
    )


class PlotOut(BaseModel):
    """One PNG plot of a tournament."""

    name: str
    title: str
    url: str


class TournamentTablesOut(BaseModel):
    """A tournament's report tables per track (then ``combined``) and its plots, over its races so far."""

    id: str
    done: int
    total: int
    tracks: dict[str, TrackTablesOut]
    ratings: list[list[str]] = Field(description="every agent's Plackett-Luce rating with its 95% interval")
    plots: list[PlotOut]
    note: str


def _spec(body: TournamentIn) -> TournamentSpec:
    spec = TournamentSpec(
        tuple(body.agents),
        tuple(body.tracks),
        body.races_per_pair,
        body.seed,
        body.laps,
        body.time_limit,
        body.kart_preset,
        conditions=body.conditions,
        team_size=body.team_size,
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
        manifest=ManifestOut.model_validate(stored.manifest.to_json()) if stored.manifest is not None else None,
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
    dependencies=[ApiKey],
    responses={
        **API_KEY_RESPONSES,
        409: {"model": ErrorOut, "description": "the id is running, or taken by other settings"},
        422: {"description": "unknown agents or tracks, bad numbers; a body that is not strict JSON"},
        429: {"model": ErrorOut, "description": "too many tournaments running (max_tournaments)"},
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


def _standing_view(standing: Standing) -> StandingOut:
    return StandingOut(
        agent=standing.agent,
        tournaments=standing.tournaments,
        races=standing.races,
        wins=standing.wins,
        win_rate=standing.win_rate,
        finished=standing.finished,
        safety_score_mean=standing.safety_score.mean,
        safety_score_std=standing.safety_score.std,
    )


def _leaderboard(runner: TournamentRunner) -> LeaderboardOut:
    groups: list[list[RaceFigures]] = []
    for stored in runner.store.list(limit=MAX_LEADERBOARD_TOURNAMENTS):
        if stored.done:
            figures = runner.store.figures(stored.id)
            if figures:
                groups.append(figures)
    standings = leaderboard(groups)
    return LeaderboardOut(
        tournaments=len(groups),
        races=sum(len(group) for group in groups),
        agents=[_standing_view(s) for s in standings],
    )


# before /tournaments/{tournament_id}, which would take "leaderboard" for an id (a reserved one: see TournamentIn)
@router.get("/tournaments/leaderboard", response_model=LeaderboardOut)
async def tournament_leaderboard(tournaments: Tournaments) -> LeaderboardOut:
    """Every agent's races, wins, win rate, races finished and safety score over the races of every stored
    tournament (:func:`arena.stats.leaderboard`), best first."""
    return await asyncio.to_thread(_leaderboard, tournaments)


@router.get(
    "/tournaments/{tournament_id}", response_model=TournamentOut, responses={404: {"description": "no such tournament"}}
)
async def get_tournament(tournament_id: str, tournaments: Tournaments, stats: bool = True) -> TournamentOut:
    """A tournament's live progress, its races so far (linked to their results and replays) and statistics
    (``?stats=false``: without them, a lighter answer to poll)."""
    stored = await _stored_or_404(tournaments, tournament_id)
    races = await asyncio.to_thread(tournaments.store.races, tournament_id)
    view = await asyncio.to_thread(_view, stored, tournaments.running(tournament_id), races, stats)
    return view


def _tables(stored: StoredTournament, figures: list[RaceFigures]) -> TournamentTablesOut:
    stats = tournament_stats(figures)
    tracks = {
        track: TrackTablesOut(
            wins=win_rows(table),
            safety=safety_rows(table),
            plan=plan_rows(table),
            start_lanes=start_lane_rows(table),
            pairs=pair_rows(table),
        )
        for track, table in stats.tracks.items()
    }
    titles = []
    for track in stats.tracks:
        shown = "all tracks" if track == COMBINED else track
        titles += [f"Head-to-head wins ({shown})", f"Safety per race ({shown})"]
    titles.append("Finish times (finished races)")
    base = f"/api/tournaments/{stored.id}/plots"
    plots = [
        PlotOut(name=stem, title=title, url=f"{base}/{stem}.png?done={stored.done}")
        for stem, title in zip(plot_stems(stats), titles, strict=True)
    ]
    note = (
        "*: significant at p = 0.05 (wins: two-sided binomial test of the pair's decided races; per-race figures: "
        "two-sided pooled t-tests, marked when significant against every other agent; start lanes: Fisher's exact "
        "test, two-sided). Intervals: 95%, Wilson for win rates, percentile bootstrap for means. Safety: mean "
        "[95% interval] and std. dev. "
        f"over all races; {METRIC_TITLES['illegal_lane_changes']} under the rule shown."
    )
    return TournamentTablesOut(
        id=stored.id,
        done=len(figures),
        total=stored.total,
        tracks=tracks,
        ratings=rating_rows(stats),
        plots=plots,
        note=note,
    )


@router.get(
    "/tournaments/{tournament_id}/tables",
    response_model=TournamentTablesOut,
    responses={404: {"description": "no such tournament"}, 409: {"description": "no finished race yet"}},
)
async def tournament_tables(tournament_id: str, tournaments: Tournaments) -> TournamentTablesOut:
    """The report's tables laid out like the paper's (wins row against column, safety, plan following) per track
    and combined, over the races so far, and the URLs of the plots."""
    stored = await _stored_or_404(tournaments, tournament_id)
    figures = await asyncio.to_thread(tournaments.store.figures, tournament_id)
    if not figures:
        raise HTTPException(status.HTTP_409_CONFLICT, f"tournament {tournament_id} has no finished race yet")
    return await asyncio.to_thread(_tables, stored, figures)


@router.get(
    "/tournaments/{tournament_id}/plots/{name}.png",
    response_class=Response,
    responses={
        200: {"content": {"image/png": {}}, "description": "the plot (names: see .../tables)"},
        404: {"description": "no such tournament or plot"},
        409: {"description": "no finished race yet"},
    },
)
async def tournament_plot(
    tournament_id: str, name: str, tournaments: Tournaments, plots: TournamentPlotsDep
) -> Response:
    """A PNG plot of the tournament's races so far (:func:`arena.report.plot_report`, Agg backend; drawn once per
    number of races stored and cached)."""
    stored = await _stored_or_404(tournaments, tournament_id)
    if not stored.done:
        raise HTTPException(status.HTTP_409_CONFLICT, f"tournament {tournament_id} has no finished race yet")
    drawn = await asyncio.to_thread(
        plots.plots, tournament_id, stored.done, lambda: tournaments.store.figures(tournament_id)
    )
    png = drawn.get(name)
    if png is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no plot {name!r}; plots: {sorted(drawn)}")
    return Response(png, media_type="image/png", headers={"Cache-Control": "no-cache"})


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
    dependencies=[ApiKey],
    responses={
        **API_KEY_RESPONSES,
        404: {"description": "no such tournament"},
        409: {"description": "not running here"},
    },
)
async def stop_tournament(tournament_id: str, tournaments: Tournaments) -> TournamentOut:
    """Stop a running tournament after the races in flight (``stopped``; POST it again to resume)."""
    await _stored_or_404(tournaments, tournament_id)
    if not await asyncio.to_thread(tournaments.stop, tournament_id, 60.0):
        raise HTTPException(status.HTTP_409_CONFLICT, f"tournament {tournament_id} is not running")
    return _view(await _stored_or_404(tournaments, tournament_id), tournaments.running(tournament_id))
