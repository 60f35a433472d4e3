"""FastAPI dependencies shared by the routes."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends
from fastapi.requests import HTTPConnection

from server.live import LiveRaces


def get_races(connection: HTTPConnection) -> LiveRaces:
    """The app's :class:`LiveRaces` (set up in the lifespan)."""
    races: LiveRaces = connection.app.state.races
    return races


Races = Annotated[LiveRaces, Depends(get_races)]
