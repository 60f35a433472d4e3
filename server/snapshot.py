"""What the API shows of a race, live or stored, in one type: a live session and a stored race each make a
:class:`RaceSnapshot` (:meth:`server.session.RaceSession.snapshot`, :meth:`server.db.StoredRace.snapshot`), and
:mod:`server.views` has one builder per resource from it."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

from server.race_config import KartEntry
from server.results import DriverFaults, KartRecord
from server.status import RaceStatus
from server.ticks import TickSummary
from web.frame import KartFrame


@dataclass(frozen=True)
class Standing:
    """One kart's place in the running order."""

    position: int
    index: int
    name: str
    controller: str
    lap: int  # current lap, 1-based, capped at the race's laps
    checkpoints_passed: int
    finished: bool
    finish_time: float | None  # [s]
    controller_faults: int

    @classmethod
    def from_frame(cls, kart: KartFrame) -> Standing:
        """A live kart's standing, from the newest frame."""
        return cls(
            kart.position,
            kart.index,
            kart.name,
            kart.controller,
            kart.lap,
            kart.checkpoints_passed,
            kart.finished,
            kart.finish_time,
            kart.controller_faults,
        )

    @classmethod
    def from_record(cls, kart: KartRecord, laps: int) -> Standing:
        """A kart's final standing, from its result in a race of ``laps`` laps."""
        referee = kart.referee
        return cls(
            referee.position,
            kart.index,
            kart.name,
            kart.controller,
            min(referee.laps_completed + 1, laps),
            referee.checkpoints_passed,
            referee.finished,
            referee.finish_time,
            kart.faults.controller_faults,
        )


@dataclass(frozen=True)
class DriverState:
    """A kart's driver: its faults so far, whether its kart brakes for want of input, and (human karts) whether
    a driver is connected."""

    kart: KartEntry
    faults: DriverFaults
    braking: bool
    driver_connected: bool | None  # None: not a human kart


@dataclass(frozen=True)
class RaceSnapshot:
    """A race as the API shows it, whether it is live or stored."""

    id: str
    created_at: datetime
    status: RaceStatus
    track: str
    laps: int
    seed: int
    kart_preset: str
    start_lanes: tuple[int, ...]  # every kart's start lane, by kart index (the defaults when none were asked)
    karts: tuple[KartEntry, ...]
    time: float  # [s] race time
    step: int
    standings: tuple[Standing, ...]  # running order
    drivers: tuple[DriverState, ...]  # by kart index
    tick_stats: TickSummary | None
    winner: int | None
    error: str | None
    recorded: bool = False  # over, with its result and replay stored
