"""FastAPI dependencies shared by the routes."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends
from fastapi.requests import HTTPConnection

from server.live import LiveRaces
from server.replays import RecordedRaces
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


def get_tournament_plots(connection: HTTPConnection) -> TournamentPlots:
    """The app's :class:`TournamentPlots` cache."""
    plots: TournamentPlots = connection.app.state.tournament_plots
    return plots


TournamentPlotsDep = Annotated[TournamentPlots, Depends(get_tournament_plots)]
