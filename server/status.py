"""The one vocabulary of race statuses, shared by the session, the database and the API."""

from __future__ import annotations

from enum import StrEnum


class RaceStatus(StrEnum):
    """Where a race is in its life (see :mod:`server.session`); the values are what the API and database show."""

    STARTING = "starting"  # world built, controllers reset, planners built, scene opened
    WAITING = "waiting"  # only with human karts: until every driver has connected and its view is ready
    COUNTDOWN = "countdown"  # only with human karts: a few seconds before the start; nothing moves
    RUNNING = "running"
    FINISHED = "finished"  # the referee's rules: everyone finished or the time limit
    STOPPED = "stopped"  # on request
    ABORTED = "aborted"  # server shutdown, a crash, or a server that died under it
    CANCELLED = "cancelled"  # a human kart's driver never came: the race did not start

    @property
    def live(self) -> bool:
        """Whether a race in this status has not ended yet."""
        return self in LIVE_STATUSES


LIVE_STATUSES = frozenset({RaceStatus.STARTING, RaceStatus.WAITING, RaceStatus.COUNTDOWN, RaceStatus.RUNNING})
OVER_STATUSES = frozenset(RaceStatus) - LIVE_STATUSES
