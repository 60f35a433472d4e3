"""FastAPI dependencies shared by the routes."""

from __future__ import annotations

import secrets
from typing import Annotated, Any

from fastapi import Depends, HTTPException, Security, status
from fastapi.requests import HTTPConnection
from fastapi.security import APIKeyHeader

from server.live import LiveRaces
from server.models import ErrorOut
from server.replays import RecordedRaces
from server.scenario_runs import ScenarioRunner
from server.settings import Settings
from server.tournament_plots import TournamentPlots
from server.tournaments import TournamentRunner


def get_races(connection: HTTPConnection) -> LiveRaces:
    """The app's :class:`LiveRaces` (set up in the lifespan)."""
    races: LiveRaces = connection.app.state.races
    return races


Races = Annotated[LiveRaces, Depends(get_races)]


def get_recorded(connection: HTTPConnection) -> RecordedRaces:
    """The app's :class:`RecordedRaces` (set up in the lifespan)."""
    recorded: RecordedRaces = connection.app.state.recorded
    return recorded


Recorded = Annotated[RecordedRaces, Depends(get_recorded)]


def get_tournaments(connection: HTTPConnection) -> TournamentRunner:
    """The app's :class:`TournamentRunner` (set up in the lifespan)."""
    runner: TournamentRunner = connection.app.state.tournaments
    return runner


Tournaments = Annotated[TournamentRunner, Depends(get_tournaments)]


def get_scenario_runs(connection: HTTPConnection) -> ScenarioRunner:
    """The app's :class:`ScenarioRunner` (set up in the lifespan)."""
    runner: ScenarioRunner = connection.app.state.scenario_runs
    return runner


ScenarioRuns = Annotated[ScenarioRunner, Depends(get_scenario_runs)]


def get_tournament_plots(connection: HTTPConnection) -> TournamentPlots:
    """The app's :class:`TournamentPlots` cache."""
    plots: TournamentPlots = connection.app.state.tournament_plots
    return plots


TournamentPlotsDep = Annotated[TournamentPlots, Depends(get_tournament_plots)]


API_KEY_HEADER = "X-API-Key"
_api_key_header = APIKeyHeader(
    name=API_KEY_HEADER,
    auto_error=False,
    description="the server's API key (KARTING_API_KEY); needed only when the server has one",
)


def require_api_key(connection: HTTPConnection, given: Annotated[str | None, Security(_api_key_header)]) -> None:
    """When the server has an API key (``KARTING_API_KEY``), refuse a request without it (401) or with another
    one (403); with none set, every request passes."""
    # an app built without settings (a bare router in tests) has no key either
    settings: Settings | None = getattr(connection.app.state, "settings", None)
    if settings is None or settings.api_key is None:
        return
    if not given:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            f"this server needs its API key in the {API_KEY_HEADER} header",
            headers={"WWW-Authenticate": API_KEY_HEADER},
        )
    if not secrets.compare_digest(given.encode(), settings.api_key.get_secret_value().encode()):
        raise HTTPException(status.HTTP_403_FORBIDDEN, f"wrong API key in the {API_KEY_HEADER} header")


ApiKey = Depends(require_api_key)
API_KEY_RESPONSES: dict[int | str, dict[str, Any]] = {
    401: {"model": ErrorOut, "description": f"the server has an API key and the {API_KEY_HEADER} header is missing"},
    403: {"model": ErrorOut, "description": "a wrong API key, or a page of a site not allowed (allowed_origins)"},
}
