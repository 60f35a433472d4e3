"""A race's result as one typed record: built once when the race ends, stored as JSON, read back into the same type.

A :class:`KartRecord` holds the referee's figures as they are (:class:`sim_core.world.KartResult`, whatever
fields it has in this version) next to the kart's identity and its controller's faults. Its JSON form is flat,
the shape ``GET /api/races/{id}/result`` shows: the referee's fields under their own names (``kart`` is the
kart's ``index``, ``laps_completed`` is ``laps``), the kart's lap times, the faults, and ``controller_faults``.
Times are written rounded to the millisecond, Δr and Δv to the millimetre (per second): the simulation's step is
20 ms, so further digits are float noise. A record stored by an older version loads too: a field it lacks takes
the field's default, or ``None``.

A record also carries the race's manifest (:mod:`arena.manifest`: the commit, every kart's controller with every
parameter, the kart preset and the conditions), ``None`` in records stored before manifests were kept.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, Field, asdict, dataclass, fields
from typing import Any

from arena.manifest import Manifest, build_manifest, describe_controller, time_limit_of
from controllers.registry import ControllerSpec
from server.race_config import KartEntry, RaceConfig
from server.status import RaceStatus
from sim_core.world import KartResult, RaceResult, grid_lanes

log = logging.getLogger(__name__)

# KartResult field -> its name in a record (and the API), where they differ
REFEREE_NAMES: Mapping[str, str] = {"kart": "index", "laps_completed": "laps"}


TIME_DIGITS = 3  # [s] to the millisecond
ROUNDED = {"finish_time": TIME_DIGITS, "delta_r": 3, "delta_v": 3}  # record field -> decimals written


def _rounded(name: str, value: Any) -> Any:
    digits = ROUNDED.get(name)
    return round(value, digits) if digits is not None and isinstance(value, float) else value


def record_name(referee_field: str) -> str:
    """The name under which a :class:`KartResult` field appears in a stored record and in the API."""
    return REFEREE_NAMES.get(referee_field, referee_field)


def _default(f: Field[Any]) -> Any:
    if f.default is not MISSING:
        return f.default
    if f.default_factory is not MISSING:
        return f.default_factory()
    return None


@dataclass(frozen=True)
class DriverFaults:
    """What a kart's controller got wrong in a race, and how many plans its tracker was given."""

    exceptions: int = 0
    hangs: int = 0
    missed_deadlines: int = 0  # ticks that found no fresh input for an observation handed over
    planner_faults: int = 0  # plans that failed or timed out
    worker_restarts: int = 0  # the process running its controller died and was restarted
    plans_applied: int = 0
    disabled: bool = False  # its controller failed to reset or hung: the kart braked from then on
    last_error: str | None = None

    @property
    def controller_faults(self) -> int:
        """Exceptions, hangs, missed deadlines, failed plans and worker restarts."""
        return self.exceptions + self.hangs + self.missed_deadlines + self.planner_faults + self.worker_restarts

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> DriverFaults:
        """The faults in a stored kart record (missing ones: their defaults)."""
        return cls(**{f.name: data.get(f.name, _default(f)) for f in fields(cls)})


@dataclass(frozen=True)
class KartRecord:
    """One kart's result: who drove it, the referee's figures and its controller's faults."""

    index: int
    name: str
    controller: str
    winner: bool
    referee: KartResult
    faults: DriverFaults
    lap_times: tuple[float, ...] = ()  # [s] each completed lap's time

    def to_json(self) -> dict[str, Any]:
        """The flat JSON form (see the module docstring)."""
        referee = {record_name(name): _rounded(record_name(name), v) for name, v in asdict(self.referee).items()}
        return {
            "index": self.index,
            "name": self.name,
            "controller": self.controller,
            **referee,
            "lap_times": [round(t, TIME_DIGITS) for t in self.lap_times],
            "winner": self.winner,
            **asdict(self.faults),
            "controller_faults": self.faults.controller_faults,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> KartRecord:
        """Read back :meth:`to_json` of this or an older version."""
        values = {f.name: data.get(record_name(f.name), _default(f)) for f in fields(KartResult)}
        pairs = {name: tuple(values[name]) for name in ("contacts_with", "passes_of")}
        referee = KartResult(**{**values, **pairs})
        return cls(
            int(data["index"]),
            str(data["name"]),
            str(data["controller"]),
            bool(data.get("winner", False)),
            referee,
            DriverFaults.from_json(data),
            tuple(float(t) for t in data.get("lap_times") or ()),
        )


@dataclass(frozen=True)
class RaceRecord:
    """A race's result: final when ``status`` is ``finished``, the state at the end otherwise."""

    race_id: str
    status: RaceStatus
    track: str
    laps: int
    duration: float  # [s] race time
    winner: int | None  # kart index of the fastest finisher; None if nobody finished
    karts: tuple[KartRecord, ...]
    seed: int | None = None  # None: stored by a version that did not record it
    kart_preset: str | None = None
    start_lanes: tuple[int, ...] | None = None  # the lanes the karts started in (the defaults when none were asked)
    end_reason: str | None = None  # why the race ended (None: stored by a version that did not say)
    manifest: Manifest | None = None  # what the race measured (None: stored by a version that kept none)

    def to_json(self) -> dict[str, Any]:
        """The JSON form stored with the race (and shown by the API)."""
        return {
            "race_id": self.race_id,
            "status": self.status.value,
            "track": self.track,
            "laps": self.laps,
            "seed": self.seed,
            "kart_preset": self.kart_preset,
            "start_lanes": list(self.start_lanes) if self.start_lanes is not None else None,
            "duration": round(self.duration, TIME_DIGITS),
            "winner": self.winner,
            "karts": [kart.to_json() for kart in self.karts],
            "end_reason": self.end_reason,
            "manifest": self.manifest.to_json() if self.manifest is not None else None,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> RaceRecord:
        """Read back :meth:`to_json` of this or an older version."""
        return cls(
            str(data["race_id"]),
            RaceStatus(data["status"]),
            str(data["track"]),
            int(data["laps"]),
            float(data["duration"]),
            data.get("winner"),
            tuple(KartRecord.from_json(kart) for kart in data["karts"]),
            data.get("seed"),
            data.get("kart_preset"),
            tuple(data["start_lanes"]) if data.get("start_lanes") is not None else None,
            data.get("end_reason"),
            Manifest.from_json(data["manifest"]) if data.get("manifest") else None,
        )

    def kart(self, index: int) -> KartRecord | None:
        """The record of kart ``index`` (None if it has none)."""
        return next((k for k in self.karts if k.index == index), None)


def race_record(
    race_id: str,
    status: RaceStatus,
    track: str,
    laps: int,
    result: RaceResult,
    karts: Sequence[KartEntry],
    faults: Sequence[DriverFaults],
    setup: RaceSetup | None = None,
    lap_times: Sequence[Sequence[float]] = (),
    end_reason: str | None = None,
    manifest: Manifest | None = None,
) -> RaceRecord:
    """The record of a race that ended with ``status`` (for ``end_reason``): the referee's ``result`` with each
    kart's identity, faults and lap times (indexed by kart), what the race was started with (``setup``) and what
    it measured (``manifest``)."""
    records = tuple(
        KartRecord(
            r.kart,
            karts[r.kart].name,
            karts[r.kart].controller,
            result.winner == r.kart,
            r,
            faults[r.kart],
            tuple(lap_times[r.kart]) if lap_times else (),  # none recorded: no lap times
        )
        for r in result.karts
    )
    seed, preset, lanes = (setup.seed, setup.kart_preset, setup.start_lanes) if setup is not None else (None,) * 3
    return RaceRecord(
        race_id, status, track, laps, result.duration, result.winner, records, seed, preset, lanes, end_reason, manifest
    )


def live_race_manifest(
    config: RaceConfig, plan_budget_s: float | None, catalogue: Mapping[str, ControllerSpec[Any]]
) -> Manifest | None:
    """The manifest of a race the server runs live from ``config`` with the controllers of ``catalogue``: plans
    apply when they arrive (no simulated latency; ``plan_budget_s`` [s] is the wall-clock time one plan may take),
    the race conditions drawn from its seed, the rules' time limit. ``None`` (logged) if it cannot be made: a result is
    stored without its manifest rather than lost."""
    conditions = {
        "track": config.track_name,
        "laps": config.laps,
        "start_lanes": list(grid_lanes(len(config.karts), config.start_lanes)),
        "conditions": config.drawn().to_json(),
        "plan_latency": None,
        "plan_budget_s": plan_budget_s,
        "seed": config.seed,
        "time_limit": time_limit_of(None),
        "live": True,
    }
    try:
        agents = [describe_controller(k.controller, k.params, lookup=catalogue.__getitem__) for k in config.karts]
        return build_manifest("race", agents, config.kart_preset, conditions)
    except Exception:
        log.exception("race manifest: could not describe the karts %s", [k.controller for k in config.karts])
        return None


@dataclass(frozen=True)
class RaceSetup:
    """What a race was started with, besides its track and karts: as its result records it."""

    seed: int
    kart_preset: str
    start_lanes: tuple[int, ...]  # every kart's start lane (the defaults when none were asked)
