"""Scenario runs started through the API (:mod:`arena.scenarios`): each runs in a background thread of the server
(its cells dealt to worker processes), and its request, status and summary are kept in the race database, so a
finished run's figures survive a restart (a run left running by a previous server process is marked ``stopped``;
start it again to race it anew: a run has no partial results).
"""

from __future__ import annotations

import logging
import threading
import uuid
from dataclasses import dataclass
from datetime import datetime
from enum import StrEnum
from typing import Any

from sqlalchemy import JSON, DateTime, String, select
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column

from arena.scenario_spec import Scenario, load_scenario
from arena.scenarios import RunStoppedError, SuiteResult, cells_of, run_cells
from server.db import RaceDatabase, utc_now

log = logging.getLogger(__name__)


class ScenarioRunStatus(StrEnum):
    """``running``, ``finished`` (its summary stored), ``stopped`` (the server stopped while it ran) or ``failed``."""

    RUNNING = "running"
    FINISHED = "finished"
    STOPPED = "stopped"
    FAILED = "failed"


class _Base(DeclarativeBase):
    pass


class ScenarioRunRow(_Base):
    """One scenario run: what was asked, where it is, and its summary once finished."""

    __tablename__ = "scenario_runs"

    id: Mapped[str] = mapped_column(String(24), primary_key=True)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    status: Mapped[str] = mapped_column(String(16), index=True)
    request: Mapped[dict[str, Any]] = mapped_column(JSON)  # ScenarioRequest.to_json()
    summary: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)  # SuiteResult.to_json()
    error: Mapped[str | None] = mapped_column(String(2000), nullable=True)


@dataclass(frozen=True)
class ScenarioRequest:
    """What a run races: scenarios by shipped name, egos and opponents (agent strings), optional tracks and paces
    (default: each scenario's), attempts per cell and the seed."""

    scenarios: tuple[str, ...]
    egos: tuple[str, ...]
    opponents: tuple[str, ...]
    tracks: tuple[str, ...] | None = None
    paces: tuple[float, ...] | None = None
    attempts: int = 10
    seed: int = 0

    def plans(self) -> list[tuple[Scenario, list[Any]]]:
        """Each scenario with its cells (``KeyError``/``ValueError`` naming what is wrong)."""
        return [
            (s, cells_of(s, self.egos, self.opponents, self.tracks, self.paces))
            for s in (load_scenario(name) for name in self.scenarios)
        ]

    def to_json(self) -> dict[str, Any]:
        """As stored and shown."""
        return {
            "scenarios": list(self.scenarios),
            "egos": list(self.egos),
            "opponents": list(self.opponents),
            "tracks": None if self.tracks is None else list(self.tracks),
            "paces": None if self.paces is None else list(self.paces),
            "attempts": self.attempts,
            "seed": self.seed,
        }


@dataclass(frozen=True)
class StoredScenarioRun:
    """A run as stored."""

    id: str
    created_at: datetime
    status: ScenarioRunStatus
    request: dict[str, Any]
    summary: dict[str, Any] | None
    error: str | None


class ScenarioRunStore:
    """Scenario runs next to the races of a :class:`~server.db.RaceDatabase` (the same engine and file)."""

    def __init__(self, db: RaceDatabase) -> None:
        self.db = db
        _Base.metadata.create_all(db.engine)

    def create(self, run_id: str, request: ScenarioRequest) -> StoredScenarioRun:
        """A new run, ``running``."""
        with Session(self.db.engine) as session, session.begin():
            row = ScenarioRunRow(
                id=run_id, created_at=utc_now(), status=ScenarioRunStatus.RUNNING.value, request=request.to_json()
            )
            session.add(row)
            session.flush()
            return _stored(row)

    def get(self, run_id: str) -> StoredScenarioRun | None:
        """The run, or ``None``."""
        with Session(self.db.engine) as session:
            row = session.get(ScenarioRunRow, run_id)
            return None if row is None else _stored(row)

    def list(self, limit: int = 100) -> list[StoredScenarioRun]:
        """The newest runs first."""
        with Session(self.db.engine) as session:
            rows = session.scalars(select(ScenarioRunRow).order_by(ScenarioRunRow.created_at.desc()).limit(limit))
            return [_stored(row) for row in rows]

    def finish(self, run_id: str, status: ScenarioRunStatus, summary: dict[str, Any] | None, error: str | None) -> None:
        """Record how the run ended."""
        with Session(self.db.engine) as session, session.begin():
            row = session.get(ScenarioRunRow, run_id)
            if row is not None:
                row.status, row.summary, row.error = status.value, summary, None if error is None else error[:2000]


def _stored(row: ScenarioRunRow) -> StoredScenarioRun:
    return StoredScenarioRun(
        row.id, row.created_at, ScenarioRunStatus(row.status), dict(row.request), row.summary, row.error
    )


class ScenarioRunner:
    """Starts the server's scenario runs (one thread each; at most ``max_running`` at once)."""

    def __init__(self, store: ScenarioRunStore, workers: int, max_running: int = 1) -> None:
        self.store = store
        self.workers = workers
        self.max_running = max_running
        self._threads: dict[str, threading.Thread] = {}
        self._stop = threading.Event()  # set at shutdown: every run stops between batches
        self._lock = threading.Lock()
        for run in store.list(limit=10_000):
            if run.status == ScenarioRunStatus.RUNNING:
                store.finish(run.id, ScenarioRunStatus.STOPPED, None, "the server stopped while it ran")

    def start(self, request: ScenarioRequest) -> StoredScenarioRun:
        """Validate ``request`` and start it in the background (``KeyError``/``ValueError``: a bad request;
        ``RuntimeError``: as many runs as allowed are running)."""
        plans = request.plans()
        with self._lock:
            self._threads = {k: t for k, t in self._threads.items() if t.is_alive()}
            if len(self._threads) >= self.max_running:
                raise RuntimeError(f"{len(self._threads)} scenario run(s) running; at most {self.max_running}")
            run_id = f"s{uuid.uuid4().hex[:10]}"
            stored = self.store.create(run_id, request)
            thread = threading.Thread(target=self._run, args=(run_id, request, plans), name=f"scenarios-{run_id}")
            thread.daemon = True
            self._threads[run_id] = thread
            thread.start()
        return stored

    def _run(self, run_id: str, request: ScenarioRequest, plans: list[tuple[Scenario, list[Any]]]) -> None:
        try:
            runs = tuple(
                (
                    s,
                    tuple(
                        run_cells(
                            s,
                            cells,
                            request.attempts,
                            request.seed,
                            workers=self.workers,
                            should_stop=self._stop.is_set,
                        )
                    ),
                )
                for s, cells in plans
            )
        except RunStoppedError as exc:
            self.store.finish(run_id, ScenarioRunStatus.STOPPED, None, str(exc))
            return
        except Exception as exc:
            log.exception("scenario run %s failed", run_id)
            self.store.finish(run_id, ScenarioRunStatus.FAILED, None, repr(exc))
            return
        summary = SuiteResult(runs, request.attempts, request.seed).to_json()
        self.store.finish(run_id, ScenarioRunStatus.FINISHED, summary, None)

    def shutdown(self, timeout: float = 30.0) -> None:
        """Stop every running run (``stopped``: its cells so far are not kept) and wait for them."""
        self._stop.set()
        with self._lock:
            threads = list(self._threads.values())
        for thread in threads:
            thread.join(timeout)
