"""Tournaments started through the API: each runs in a background thread of the server (which waits on a pool of
worker processes, :func:`arena.tournament.run_tournament`), storing races as they finish; the API reads progress
and results from the database, so they survive a restart (a tournament left running by a previous server process
is marked ``stopped``, and resumes when started again with the same id and settings).
"""

from __future__ import annotations

import logging
import threading
import uuid
from dataclasses import dataclass, field

from arena.tournament import TournamentSpec, run_tournament
from server.tournament_db import StoredTournament, TournamentDatabase, TournamentStatus

log = logging.getLogger(__name__)


class TournamentConflictError(Exception):
    """The tournament is already running here, or its id is taken by other settings."""


class TooManyTournamentsError(Exception):
    """As many tournaments as the settings allow are running."""


@dataclass
class _Running:
    thread: threading.Thread
    stop: threading.Event = field(default_factory=threading.Event)


class TournamentRunner:
    """Starts, stops and tracks the server's tournaments (one thread each; at most ``max_running`` at once)."""

    def __init__(self, store: TournamentDatabase, workers: int, max_running: int) -> None:
        self.store = store
        self.workers = workers
        self.max_running = max_running
        self._running: dict[str, _Running] = {}
        self._lock = threading.Lock()
        for stale in store.list(limit=10_000):
            if stale.status == TournamentStatus.RUNNING:
                store.set_status(stale.id, TournamentStatus.STOPPED, "the server stopped while it ran")

    def running(self, tournament_id: str) -> bool:
        """Whether the tournament runs in this process now."""
        with self._lock:
            entry = self._running.get(tournament_id)
            return entry is not None and entry.thread.is_alive()

    def start(self, spec: TournamentSpec, tournament_id: str | None = None) -> StoredTournament:
        """Create (or resume) a tournament and start running it in the background."""
        tid = tournament_id or f"t{uuid.uuid4().hex[:10]}"
        with self._lock:
            self._running = {k: v for k, v in self._running.items() if v.thread.is_alive()}
            if tid in self._running:
                raise TournamentConflictError(f"tournament {tid!r} is already running")
            if len(self._running) >= self.max_running:
                raise TooManyTournamentsError(f"{len(self._running)} tournament(s) running; at most {self.max_running}")
            try:
                stored = self.store.create(tid, spec)
            except ValueError as exc:
                raise TournamentConflictError(str(exc)) from None
            entry = _Running(threading.Thread(target=self._run, args=(tid, spec), name=f"tournament-{tid}"))
            entry.thread.daemon = True
            self._running[tid] = entry
            entry.thread.start()
        return stored

    def _run(self, tournament_id: str, spec: TournamentSpec) -> None:
        stop = self._running[tournament_id].stop
        try:
            run_tournament(spec, self.store, tournament_id, workers=self.workers, should_stop=stop.is_set)
        except Exception as exc:
            log.exception("tournament %s failed", tournament_id)
            self.store.set_status(tournament_id, TournamentStatus.FAILED, repr(exc)[:2000])
            return
        stored = self.store.get(tournament_id)
        complete = stored is not None and stored.done == stored.total
        self.store.set_status(tournament_id, TournamentStatus.FINISHED if complete else TournamentStatus.STOPPED)

    def stop(self, tournament_id: str, timeout: float | None = None) -> bool:
        """Ask a running tournament to stop after its current races; wait up to ``timeout`` [s]. False: it was
        not running here."""
        with self._lock:
            entry = self._running.get(tournament_id)
        if entry is None or not entry.thread.is_alive():
            return False
        entry.stop.set()
        entry.thread.join(timeout)
        return True

    def shutdown(self, timeout: float = 30.0) -> None:
        """Stop every running tournament (they stay resumable)."""
        with self._lock:
            entries = list(self._running.values())
        for entry in entries:
            entry.stop.set()
        for entry in entries:
            entry.thread.join(timeout)
