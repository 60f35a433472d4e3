"""The races this server process is running, and what they share (:class:`~server.services.RaceServices`)."""

from __future__ import annotations

import asyncio
import logging
import secrets

from server.db import StoredRace
from server.race_config import RaceConfig
from server.services import RaceServices
from server.session import RaceSession
from server.status import RaceStatus

log = logging.getLogger(__name__)

SHUTDOWN_WAIT_S = 10.0  # [s] for every race to store its state when the server stops


class TooManyRacesError(RuntimeError):
    """The server already runs ``max_sessions`` live races."""


class LiveRaces:
    """Live races by id (and finished ones for ``keep_finished_s``); starts and ends them."""

    def __init__(self, services: RaceServices) -> None:
        self.services = services
        self.settings = services.settings
        self.sessions: dict[str, RaceSession] = {}
        # creates past the limit check and not registered yet: they hold a slot, so that concurrent creates
        # cannot all pass the check while the first ones wait for the database
        self._reserved = 0

    def get(self, race_id: str) -> RaceSession | None:
        """A race held in memory, or ``None``."""
        return self.sessions.get(race_id)

    def live_count(self) -> int:
        """Races not over yet."""
        return sum(1 for s in self.sessions.values() if s.live)

    def scene_port(self, race_id: str) -> int | None:
        """The local port of a race's 3D scene (``None``: no such race or no scene)."""
        session = self.sessions.get(race_id)
        scene = session.scene if session is not None else None
        return scene.port if scene is not None else None

    def status(self, race_id: str) -> RaceStatus | None:
        """A race's status, from memory or the database (``None``: no such race; blocking: call it in a thread)."""
        session = self.sessions.get(race_id)
        return session.status if session is not None else self.services.db.status(race_id)

    async def create(self, config: RaceConfig) -> RaceSession:
        """Store and start a race; raises :class:`TooManyRacesError` when the server is full.

        The check and the slot's reservation happen with no ``await`` between them (one step of the event loop,
        which is the lock here), and the slot stays reserved until the race is registered as live or the
        create fails."""
        if self.live_count() + self._reserved >= self.settings.max_sessions:
            raise TooManyRacesError(f"{self.settings.max_sessions} races are running; try again when one ends")
        self._reserved += 1
        try:
            return await self._create(config)
        finally:
            self._reserved -= 1

    async def _create(self, config: RaceConfig) -> RaceSession:
        race_id = secrets.token_hex(6)
        tokens = {kart.index: secrets.token_urlsafe(16) for kart in config.karts if kart.human}
        session = RaceSession(race_id, config, tokens, self.services)
        stored = StoredRace(
            id=race_id,
            created_at=session.created_at,
            status=session.status,
            track=config.track_name,
            laps=config.laps,
            seed=config.seed,
            kart_preset=config.kart_preset,
            karts=list(config.karts),
            start_lanes=list(config.start_lanes) if config.start_lanes is not None else None,
            duration=None,
            result=None,
            tick_stats=None,
        )
        await asyncio.to_thread(self.services.db.add, stored)
        self.sessions[race_id] = session
        session.on_closed = self._forget
        session.other_starts = lambda: [
            s.schedule.t0 for s in self.sessions.values() if s is not session and s.live and s.schedule is not None
        ]
        session.start()
        return session

    def _forget(self, session: RaceSession) -> None:
        self.sessions.pop(session.id, None)

    async def shutdown(self) -> None:
        """End every race (live ones as ``aborted``, with their state stored) and close their scenes."""
        sessions = list(self.sessions.values())
        for session in sessions:
            session.close()
        tasks = [s.task for s in sessions if s.task is not None]
        if not tasks:
            return
        _done, pending = await asyncio.wait(tasks, timeout=SHUTDOWN_WAIT_S)
        for task in pending:
            log.warning("race task %s did not end in time; cancelling it", task.get_name())
            task.cancel()
