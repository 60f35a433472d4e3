"""Tournaments in the race database: one row per tournament (its spec and status) and one per stored race, which
links a schedule index to a race of the ``races`` table (result and replay there, as for any race the server ran).

:class:`TournamentDatabase` is the :class:`arena.tournament.RaceStore` of the command line and the server: a race
and its link are written in one transaction, so a runner killed at any moment leaves each race stored whole or
not at all, and a resumed run re-runs exactly the missing ones.

Each tournament keeps the manifest it was created with (:meth:`arena.tournament.TournamentSpec.manifest`: commit,
agents with every parameter, kart, conditions) and each race its own, made by the process that raced it. A
tournament resumes only while its agents resolve as they did when it was created: one whose agents changed since
(a default, trained weights) is refused, since its races would describe two different agents under one name.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import UTC, datetime
from enum import StrEnum
from typing import Any

from sqlalchemy import JSON, DateTime, Float, ForeignKey, Integer, String, func, select, update
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column

from arena.manifest import Manifest, stale_agents
from arena.publish import Tournament
from arena.race import FinishedRace, RaceJob, race_figures
from arena.records import RaceFigures
from arena.tournament import TournamentSpec
from server.db import RaceDatabase, RaceRow, encode_replay, utc_now
from server.limits import default_kart_name
from server.race_config import KartEntry
from server.results import DriverFaults, RaceRecord, RaceSetup, race_record
from server.status import RaceStatus
from sim_core.world import grid_lanes

TOURNAMENT_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,23}$")  # race ids are TOURNAMENT-NNNNN (32 characters)


class TournamentStatus(StrEnum):
    """Where a tournament is: ``running``, ``finished`` (every race stored), ``stopped`` (interrupted, resumable)
    or ``failed`` (a race raised; resumable after the fix)."""

    RUNNING = "running"
    FINISHED = "finished"
    STOPPED = "stopped"
    FAILED = "failed"


class _Base(DeclarativeBase):
    pass


class TournamentRow(_Base):
    """One tournament: its spec and status."""

    __tablename__ = "tournaments"

    id: Mapped[str] = mapped_column(String(24), primary_key=True)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    status: Mapped[str] = mapped_column(String(16), index=True)
    spec: Mapped[dict[str, Any]] = mapped_column(JSON)  # TournamentSpec.to_json()
    total: Mapped[int] = mapped_column(Integer)
    error: Mapped[str | None] = mapped_column(String(2000), nullable=True)


class TournamentManifestRow(_Base):
    """A tournament's manifest (a table of its own, so that a database made before manifests gains it as it is
    opened, with no migration; its tournaments have none)."""

    __tablename__ = "tournament_manifests"

    tournament_id: Mapped[str] = mapped_column(ForeignKey("tournaments.id"), primary_key=True)
    manifest: Mapped[dict[str, Any]] = mapped_column(JSON)  # Manifest.to_json()


class TournamentRaceRow(_Base):
    """A stored race of a tournament: its schedule index, the race's row and the wall time it took."""

    __tablename__ = "tournament_races"

    tournament_id: Mapped[str] = mapped_column(ForeignKey("tournaments.id"), primary_key=True)
    index: Mapped[int] = mapped_column(Integer, primary_key=True)
    race_id: Mapped[str] = mapped_column(ForeignKey(RaceRow.id))
    seed: Mapped[int] = mapped_column(Integer)
    wall_seconds: Mapped[float] = mapped_column(Float)


@dataclass(frozen=True)
class StoredTournament:
    """A tournament as read back: spec, status, races stored of the total."""

    id: str
    created_at: datetime
    status: TournamentStatus
    spec: TournamentSpec
    total: int
    done: int
    error: str | None
    manifest: Manifest | None = None  # None: created before manifests were kept


@dataclass(frozen=True)
class TournamentRace:
    """One stored race of a tournament: its job, its result record and the wall time it took."""

    job: RaceJob
    race_id: str
    record: RaceRecord
    wall_seconds: float

    def figures(self) -> RaceFigures:
        """The race's figures for the statistics."""
        return race_figures(self.job, [k.referee for k in self.record.karts], self.record.duration, self.race_id)


def race_id(tournament_id: str, index: int) -> str:
    """The id of a tournament's race ``index`` in the ``races`` table."""
    return f"{tournament_id}-{index:05d}"


class TournamentDatabase:
    """Tournaments next to the races of a :class:`~server.db.RaceDatabase` (the same engine and file)."""

    def __init__(self, db: RaceDatabase) -> None:
        self.db = db
        _Base.metadata.create_all(db.engine)

    def create(self, tournament_id: str, spec: TournamentSpec) -> StoredTournament:
        """A new tournament with its manifest, or the stored one with this id and the same spec (to resume; status
        ``running``). ``ValueError``: a bad id, the id is taken by a different spec, or the stored tournament's
        agents resolve differently now (:func:`arena.manifest.stale_agents`)."""
        if not TOURNAMENT_ID.match(tournament_id):
            raise ValueError(f"tournament ids are 1-24 letters, digits, '-' or '_', got {tournament_id!r}")
        manifest = spec.manifest()
        with Session(self.db.engine) as session, session.begin():
            row = session.get(TournamentRow, tournament_id)
            if row is None:
                session.add(
                    TournamentRow(
                        id=tournament_id,
                        created_at=utc_now(),
                        status=TournamentStatus.RUNNING.value,
                        spec=spec.to_json(),
                        total=spec.total,
                    )
                )
                session.flush()  # the tournament before the manifest that references it
                session.add(TournamentManifestRow(tournament_id=tournament_id, manifest=manifest.to_json()))
            elif TournamentSpec.from_json(row.spec) != spec:
                raise ValueError(f"tournament {tournament_id!r} exists with another spec: {row.spec}")
            else:
                kept = session.get(TournamentManifestRow, tournament_id)
                changed = stale_agents(Manifest.from_json(kept.manifest)) if kept is not None else []
                if changed:
                    raise ValueError(
                        f"tournament {tournament_id!r} cannot resume: its agents changed since it started "
                        f"({'; '.join(changed)}); run it under a new id"
                    )
                row.status, row.error = TournamentStatus.RUNNING.value, None
        stored = self.get(tournament_id)
        assert stored is not None
        return stored

    def set_status(self, tournament_id: str, status: TournamentStatus, error: str | None = None) -> None:
        """Change a tournament's status (and error)."""
        with Session(self.db.engine) as session, session.begin():
            values = {"status": TournamentStatus(status).value, "error": error}
            session.execute(update(TournamentRow).where(TournamentRow.id == tournament_id).values(**values))

    def finished_indices(self, tournament_id: str) -> set[int]:
        """Schedule indices of the stored races."""
        with Session(self.db.engine) as session:
            query = select(TournamentRaceRow.index).where(TournamentRaceRow.tournament_id == tournament_id)
            return set(session.scalars(query))

    def save(self, tournament_id: str, race: FinishedRace) -> None:
        """Store a finished race (result and replay in ``races``) and its link, in one transaction."""
        job = race.job
        rid = race_id(tournament_id, job.index)
        karts = [KartEntry(k, default_kart_name(agent, k), agent) for k, agent in enumerate(job.agents)]
        setup = RaceSetup(job.seed, job.kart_preset, grid_lanes(len(karts), tuple(job.start_lanes)))
        faults = [DriverFaults()] * len(karts)
        record = race_record(
            rid,
            RaceStatus.FINISHED,
            job.track,
            race.laps,
            race.result,
            karts,
            faults,
            setup,
            race.lap_times,
            manifest=race.manifest,
        )
        with Session(self.db.engine) as session, session.begin():
            session.add(
                RaceRow(
                    id=rid,
                    created_at=utc_now(),
                    status=RaceStatus.FINISHED.value,
                    track=job.track,
                    laps=race.laps,
                    seed=job.seed,
                    kart_preset=job.kart_preset,
                    karts=[kart.to_json() for kart in karts],
                    start_lanes=list(job.start_lanes),
                    duration=race.result.duration,
                    result=record.to_json(),
                    tick_stats={},
                    replay=encode_replay(race.replay) if race.replay is not None else None,
                )
            )
            session.flush()  # the race row before the link that references it
            session.add(
                TournamentRaceRow(
                    tournament_id=tournament_id,
                    index=job.index,
                    race_id=rid,
                    seed=job.seed,
                    wall_seconds=race.wall_seconds,
                )
            )

    def exists(self, tournament_id: str) -> bool:
        """Whether there is a tournament ``tournament_id``."""
        with Session(self.db.engine) as session:
            return session.get(TournamentRow, tournament_id) is not None

    def get(self, tournament_id: str) -> StoredTournament | None:
        """One tournament, or ``None``."""
        with Session(self.db.engine) as session:
            row = session.get(TournamentRow, tournament_id)
            if row is None:
                return None
            done = session.scalar(
                select(func.count()).select_from(TournamentRaceRow).where(TournamentRaceRow.tournament_id == row.id)
            )
            manifest = session.get(TournamentManifestRow, row.id)
            return _stored(row, int(done or 0), Manifest.from_json(manifest.manifest) if manifest else None)

    def races(self, tournament_id: str) -> list[TournamentRace]:
        """The stored races in schedule order."""
        stored = self.get(tournament_id)
        if stored is None:
            return []
        jobs = {job.index: job for job in stored.spec.jobs()}
        with Session(self.db.engine) as session:
            query = (
                select(TournamentRaceRow, RaceRow.result)
                .join(RaceRow, RaceRow.id == TournamentRaceRow.race_id)
                .where(TournamentRaceRow.tournament_id == tournament_id)
                .order_by(TournamentRaceRow.index)
            )
            rows = [(link.index, link.race_id, link.wall_seconds, result) for link, result in session.execute(query)]
        return [
            TournamentRace(jobs[index], rid, RaceRecord.from_json(result), wall)
            for index, rid, wall, result in rows
            if result is not None
        ]

    def publishable(self, tournament_id: str) -> Tournament | None:
        """The tournament as :func:`arena.publish.publish` reads it (``None``: no such tournament)."""
        stored = self.get(tournament_id)
        if stored is None:
            return None
        races = self.races(tournament_id)
        figures = [race.figures() for race in races]
        manifests = [race.record.manifest for race in races]
        return Tournament(tournament_id, stored.spec.to_json(), stored.total, stored.manifest, figures, manifests)

    def figures(self, tournament_id: str) -> list[RaceFigures]:
        """The stored races' figures in schedule order (the statistics' input)."""
        return [race.figures() for race in self.races(tournament_id)]

    # last: the name list would shadow the builtin in the annotations below it
    def list(self, limit: int = 100) -> list[StoredTournament]:
        """The newest ``limit`` tournaments, newest first."""
        with Session(self.db.engine) as session:
            rows = list(session.scalars(select(TournamentRow).order_by(TournamentRow.created_at.desc()).limit(limit)))
        return [t for row in rows if (t := self.get(row.id)) is not None]


def _stored(row: TournamentRow, done: int, manifest: Manifest | None) -> StoredTournament:
    created = row.created_at if row.created_at.tzinfo else row.created_at.replace(tzinfo=UTC)  # SQLite drops it
    spec = TournamentSpec.from_json(row.spec)
    status = TournamentStatus(row.status)
    return StoredTournament(row.id, created, status, spec, row.total, done, row.error, manifest)
