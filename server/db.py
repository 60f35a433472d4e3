"""Where races, results and replays are kept: SQLAlchemy 2 (sync engine, called through ``asyncio.to_thread``).

SQLite by default, opened in WAL mode so readers never wait for the writer. One row per race; the result and
the replay are JSON (the replay zlib-compressed: tens of thousands of numbers per race).
"""

from __future__ import annotations

import json
import zlib
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import JSON, DateTime, Float, Integer, LargeBinary, String, create_engine, event, select, update
from sqlalchemy.engine import Engine
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column

from server.race_config import KartEntry
from server.results import DriverFaults, RaceRecord
from server.snapshot import DriverState, RaceSnapshot, Standing
from server.status import LIVE_STATUSES, RaceStatus
from server.ticks import TickSummary
from sim_core.params import DT
from sim_core.world import grid_lanes


class _Base(DeclarativeBase):
    pass


class RaceRow(_Base):
    """One race: what was asked for, how it went, and (once over) its result and replay."""

    __tablename__ = "races"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    status: Mapped[str] = mapped_column(String(16), index=True)
    track: Mapped[str] = mapped_column(String(128))
    laps: Mapped[int] = mapped_column(Integer)
    seed: Mapped[int] = mapped_column(Integer)
    kart_preset: Mapped[str] = mapped_column(String(32))
    karts: Mapped[list[dict[str, Any]]] = mapped_column(JSON)  # [KartEntry.to_json()]
    start_lanes: Mapped[list[int] | None] = mapped_column(JSON, nullable=True)
    duration: Mapped[float | None] = mapped_column(Float, nullable=True)  # [s] race time
    result: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)  # RaceRecord.to_json()
    tick_stats: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)  # TickSummary
    replay: Mapped[bytes | None] = mapped_column(LargeBinary, nullable=True)  # zlib(JSON)


@dataclass(frozen=True)
class StoredRace:
    """A race as read back from the database (without its replay)."""

    id: str
    created_at: datetime
    status: RaceStatus
    track: str
    laps: int
    seed: int
    kart_preset: str
    karts: list[KartEntry]
    start_lanes: list[int] | None
    duration: float | None
    result: RaceRecord | None
    tick_stats: TickSummary | None

    def lanes_used(self) -> tuple[int, ...]:
        """Every kart's start lane: as its result recorded them, else as asked, else the defaults."""
        recorded = self.result.start_lanes if self.result is not None else None
        asked = tuple(self.start_lanes) if self.start_lanes is not None else None
        return recorded or grid_lanes(len(self.karts), asked)

    def snapshot(self) -> RaceSnapshot:
        """The race as the API shows it: its result's standings and faults (a human kart's driver is gone)."""
        record = self.result
        standings = sorted(record.karts, key=lambda k: k.referee.position) if record is not None else []
        drivers = []
        for kart in self.karts:
            kart_record = record.kart(kart.index) if record is not None else None
            faults = kart_record.faults if kart_record is not None else DriverFaults()
            drivers.append(DriverState(kart, faults, False, False if kart.human else None))
        return RaceSnapshot(
            id=self.id,
            created_at=self.created_at,
            status=self.status,
            track=self.track,
            laps=self.laps,
            seed=self.seed,
            kart_preset=self.kart_preset,
            start_lanes=self.lanes_used(),
            karts=tuple(self.karts),
            time=self.duration or 0.0,
            step=round((self.duration or 0.0) / DT),
            standings=tuple(Standing.from_record(k, self.laps) for k in standings),
            drivers=tuple(drivers),
            tick_stats=self.tick_stats,
            winner=record.winner if record is not None else None,
            error=None,
            recorded=record is not None,
        )


def _stored(row: RaceRow) -> StoredRace:
    return StoredRace(
        row.id,
        row.created_at if row.created_at.tzinfo else row.created_at.replace(tzinfo=UTC),  # SQLite drops the zone
        RaceStatus(row.status),
        row.track,
        row.laps,
        row.seed,
        row.kart_preset,
        [KartEntry.from_json(kart) for kart in row.karts],
        row.start_lanes,
        row.duration,
        RaceRecord.from_json(row.result) if row.result is not None else None,
        TickSummary(**row.tick_stats) if row.tick_stats else None,
    )


class RaceDatabase:
    """Races, results and replays in a SQL database (blocking calls: run them in a thread)."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.engine: Engine = create_engine(url)
        if self.engine.dialect.name == "sqlite":
            event.listen(self.engine, "connect", _sqlite_pragmas)
        _Base.metadata.create_all(self.engine)

    def close(self) -> None:
        """Release every pooled connection."""
        self.engine.dispose()

    def abort_unfinished(self) -> int:
        """Mark races left live by a previous server process as ``aborted``; returns how many."""
        with Session(self.engine) as session, session.begin():
            live = [status.value for status in LIVE_STATUSES]
            aborted = RaceStatus.ABORTED.value
            done = session.execute(update(RaceRow).where(RaceRow.status.in_(live)).values(status=aborted))
            return int(done.rowcount)  # type: ignore[attr-defined]

    def add(self, race: StoredRace) -> None:
        """Insert a new race."""
        with Session(self.engine) as session, session.begin():
            session.add(
                RaceRow(
                    id=race.id,
                    created_at=race.created_at,
                    status=RaceStatus(race.status).value,
                    track=race.track,
                    laps=race.laps,
                    seed=race.seed,
                    kart_preset=race.kart_preset,
                    karts=[kart.to_json() for kart in race.karts],
                    start_lanes=race.start_lanes,
                )
            )

    def set_status(self, race_id: str, status: RaceStatus) -> None:
        """Change a race's status."""
        with Session(self.engine) as session, session.begin():
            session.execute(update(RaceRow).where(RaceRow.id == race_id).values(status=RaceStatus(status).value))

    def finish(self, race_id: str, result: RaceRecord, tick_stats: TickSummary | None, replay: dict[str, Any]) -> None:
        """Store the end of a race: final status, result, tick statistics and replay."""
        blob = encode_replay(replay)
        ticks = asdict(tick_stats) if tick_stats is not None else {}
        values = {"status": result.status.value, "duration": result.duration, "result": result.to_json()}
        with Session(self.engine) as session, session.begin():
            session.execute(
                update(RaceRow).where(RaceRow.id == race_id).values(**values, tick_stats=ticks, replay=blob)
            )

    def get(self, race_id: str) -> StoredRace | None:
        """One race, or ``None``."""
        with Session(self.engine) as session:
            row = session.get(RaceRow, race_id)
            return _stored(row) if row is not None else None

    def status(self, race_id: str) -> RaceStatus | None:
        """A race's status alone (``None``: no such race)."""
        with Session(self.engine) as session:
            value = session.scalar(select(RaceRow.status).where(RaceRow.id == race_id))
        return RaceStatus(value) if value is not None else None

    def list(self, limit: int = 200) -> list[StoredRace]:
        """The newest ``limit`` races, newest first."""
        with Session(self.engine) as session:
            rows = session.scalars(select(RaceRow).order_by(RaceRow.created_at.desc()).limit(limit))
            return [_stored(row) for row in rows]

    def replay(self, race_id: str) -> dict[str, Any] | None:
        """A race's replay, or ``None`` when it has none (yet)."""
        with Session(self.engine) as session:
            blob = session.scalar(select(RaceRow.replay).where(RaceRow.id == race_id))
        if blob is None:
            return None
        data: dict[str, Any] = json.loads(zlib.decompress(blob))
        return data


def encode_replay(replay: dict[str, Any]) -> bytes:
    """A replay as stored: compact JSON, zlib-compressed."""
    return zlib.compress(json.dumps(replay, separators=(",", ":")).encode(), 6)


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA synchronous=NORMAL")  # safe with WAL; a power cut may lose the last commit only
    cursor.execute("PRAGMA busy_timeout=5000")
    cursor.close()


def utc_now() -> datetime:
    """The current time, timezone-aware (UTC)."""
    return datetime.now(UTC)
