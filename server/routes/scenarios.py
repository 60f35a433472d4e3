"""Scenarios (:mod:`arena.scenarios`): the shipped ones (``GET /api/scenarios``), and runs of their cells started
in the background (``POST /api/scenarios/runs``), listed and read with their figures once finished
(``GET /api/scenarios/runs``, ``GET /api/scenarios/runs/{id}``)."""

from __future__ import annotations

import asyncio
from datetime import datetime
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, status
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from arena.scenario_spec import load_scenario, shipped_scenarios
from controllers.registry import PACE_SEPARATOR, validate_agent
from server.deps import API_KEY_RESPONSES, ApiKey, ScenarioRuns
from server.limits import MAX_SEED
from server.models import ErrorOut, JsonInt, Name, not_a_bool
from server.scenario_runs import ScenarioRequest, StoredScenarioRun
from server.strict_json import StrictJSONRoute
from sim_core.params import MIN_PACE
from sim_core.track_io import get_track

router = APIRouter(route_class=StrictJSONRoute)
MAX_ATTEMPTS = 200
MAX_CELLS = 200


class ScenarioOut(BaseModel):
    """A shipped scenario (``scenarios/NAME.json``)."""

    name: str
    kind: str
    description: str
    tracks: list[str]
    place: str
    gap_m: list[float]
    paces: list[float]
    laps: int
    conditions: str
    backmarker: str = Field(description="lapping: the slower kart's agent")
    rival_gap_m: list[float] = Field(description="lapping: the opponent's distance behind the ego [m]")
    karts: int = Field(description="start: karts on the grid")


class ScenarioRunIn(BaseModel):
    """A run: every cell (scenario, track, ego, opponent, pace) raced ``attempts`` times."""

    model_config = ConfigDict(extra="forbid")

    scenarios: list[Name] = Field(min_length=1, max_length=8, description="names from GET /api/scenarios")
    egos: list[Name] = Field(min_length=1, max_length=8, description="agents (GET /api/controllers, NAME:KEY=VALUE)")
    opponents: list[Name] = Field(min_length=1, max_length=8, description="agents; an ego never meets itself")
    tracks: list[Name] | None = Field(None, min_length=1, max_length=8, description="default: each scenario's")
    paces: list[Annotated[float, Field(ge=MIN_PACE, le=1.0), BeforeValidator(not_a_bool)]] | None = Field(
        None, min_length=1, max_length=10, description="default: each scenario's ladder"
    )
    attempts: JsonInt = Field(10, ge=1, le=MAX_ATTEMPTS, description="seeded attempts per cell")
    seed: JsonInt = Field(0, ge=0, le=MAX_SEED)


class ScenarioRunOut(BaseModel):
    """A run: what it races, where it is, and (finished) its summary: every cell's figures with 95% intervals
    and the pass thresholds (as ``karting scenarios run --json``)."""

    id: str
    created_at: datetime
    status: str
    request: dict[str, Any]
    summary: dict[str, Any] | None
    error: str | None
    url: str


def _view(run: StoredScenarioRun) -> ScenarioRunOut:
    return ScenarioRunOut(
        id=run.id,
        created_at=run.created_at,
        status=run.status.value,
        request=run.request,
        summary=run.summary,
        error=run.error,
        url=f"/api/scenarios/runs/{run.id}",
    )


@router.get("/scenarios", response_model=list[ScenarioOut])
def list_scenarios() -> list[ScenarioOut]:
    """The shipped scenarios."""
    return [ScenarioOut(**load_scenario(name).to_json()) for name in shipped_scenarios()]


def _request(body: ScenarioRunIn) -> ScenarioRequest:
    request = ScenarioRequest(
        tuple(body.scenarios),
        tuple(body.egos),
        tuple(body.opponents),
        None if body.tracks is None else tuple(body.tracks),
        None if body.paces is None else tuple(body.paces),
        body.attempts,
        body.seed,
    )
    errors = [
        _error(("scenarios", i), f"unknown scenario {name!r}; shipped: {shipped_scenarios()}", name)
        for i, name in enumerate(body.scenarios)
        if name not in shipped_scenarios()
    ]
    for field in ("egos", "opponents"):
        for i, agent in enumerate(getattr(body, field)):
            try:
                validate_agent(agent)
                if PACE_SEPARATOR in agent:
                    raise ValueError("a scenario sets the pace: name the agent without @PACE")
            except (KeyError, ValueError) as exc:
                errors.append(_error((field, i), str(exc), agent))
    for i, track in enumerate(body.tracks or ()):
        try:
            get_track(track)  # built-in tracks only: a request names no files
        except KeyError as exc:
            errors.append(_error(("tracks", i), str(exc), track))
    if not errors:
        cells = sum(len(cells) for _, cells in request.plans())
        if not 1 <= cells <= MAX_CELLS:
            errors.append(_error(("opponents",), f"{cells} cells (the egos never meet themselves); a run has 1 to "
                                 f"{MAX_CELLS}", body.opponents))  # fmt: skip
    if errors:
        raise RequestValidationError(errors)
    return request


def _error(loc: tuple[str | int, ...], message: str, value: object) -> dict[str, Any]:
    return {"type": "value_error", "loc": ("body", *loc), "msg": message.strip("'\""), "input": value}


@router.post(
    "/scenarios/runs",
    status_code=status.HTTP_202_ACCEPTED,
    response_model=ScenarioRunOut,
    dependencies=[ApiKey],
    responses={
        **API_KEY_RESPONSES,
        422: {"description": "unknown scenarios, agents or tracks, bad paces; a body that is not strict JSON"},
        429: {"model": ErrorOut, "description": "as many scenario runs as allowed are running"},
    },
)
async def start_run(body: ScenarioRunIn, runs: ScenarioRuns) -> ScenarioRunOut:
    """Start a run (in the background: follow ``url``)."""
    request = _request(body)
    try:
        stored = await asyncio.to_thread(runs.start, request)
    except RuntimeError as exc:
        raise HTTPException(status.HTTP_429_TOO_MANY_REQUESTS, str(exc)) from None
    return _view(stored)


@router.get("/scenarios/runs", response_model=list[ScenarioRunOut])
async def list_runs(runs: ScenarioRuns) -> list[ScenarioRunOut]:
    """The newest runs first."""
    return [_view(run) for run in await asyncio.to_thread(runs.store.list)]


@router.get("/scenarios/runs/{run_id}", response_model=ScenarioRunOut, responses={404: {"model": ErrorOut}})
async def get_run(run_id: str, runs: ScenarioRuns) -> ScenarioRunOut:
    """One run, with its summary once finished."""
    run = await asyncio.to_thread(runs.store.get, run_id)
    if run is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no scenario run {run_id!r}")
    return _view(run)
