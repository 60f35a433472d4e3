"""A finished race's figures for its page: laps and sectors, gaps, positions by lap, speed along the lap, tyre
wear and the incidents, derived from its :class:`~controllers.timeline.RaceTimeline` (pure: no I/O).

Lap ``l`` (1-based) ends when a kart crosses absolute checkpoint ``l * N``; lap 1 starts at the start signal
(race time 0), every later lap where the one before ended. A lap is cut into :data:`SECTORS` sectors at the
checkpoints :func:`sector_ends` names. Gaps are to the first kart to complete the same lap; positions by lap
are the order in which karts completed it.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from controllers.timeline import Crossing, Incident, RaceTimeline
from server.results import TIME_DIGITS

SECTORS = 3
SPEED_BINS = 100  # points of the speed-along-the-lap trace per lap
WEAR_PERIOD = 0.5  # [s] between tyre wear samples


@dataclass(frozen=True)
class LapReport:
    """One kart's lap: its time, sector times, and where it stood when it completed the lap."""

    lap: int  # 1-based
    time: float  # [s] lap time
    sectors: tuple[float, ...]  # [s] sector times
    end_time: float  # [s] race time at the end of the lap
    position: int  # order in which the karts completed this lap (1 = first)
    gap: float  # [s] behind the first kart to complete this lap
    wear: float  # [-] tyre wear at the end of the lap
    speed: float  # [m/s] speed over the line


@dataclass(frozen=True)
class KartReport:
    """One kart's race: its laps, best lap, gap to the winner and its traces."""

    index: int
    laps: tuple[LapReport, ...]
    best_lap: int | None  # lap number of its fastest lap
    gap_to_winner: float | None  # [s] finish-time gap (None: it or nobody finished)
    top_speed: float  # [m/s]
    speed_by_lap: tuple[tuple[float | None, ...], ...]  # [m/s] per lap, mean speed per distance bin (None: no data)
    wear: tuple[float, ...]  # [-] tyre wear at each of RaceReport.wear_times


@dataclass(frozen=True)
class IncidentReport:
    """An incident with the lap it happened on (see :class:`controllers.timeline.Incident`)."""

    time: float  # [s]
    kart: int
    kind: str  # collision_at_fault, illegal_lane_change, wall_hit or pass
    other: int | None
    lap: int  # 1-based


@dataclass(frozen=True)
class RaceReport:
    """A race's figures for its page (see the module docstring)."""

    race_id: str
    laps: int
    duration: float  # [s]
    n_checkpoints: int
    track_length: float  # [m]
    sector_ends: tuple[int, ...]  # checkpoints (within a lap) where the sectors end
    distance_bins: tuple[float, ...]  # [m] centre of each speed-trace bin along the lap
    wear_times: tuple[float, ...]  # [s]
    karts: tuple[KartReport, ...]
    incidents: tuple[IncidentReport, ...]
    pose_error: float  # [m] re-simulated vs recorded positions (0: the figures are exact)


def _ms(seconds: float) -> float:
    return round(seconds, TIME_DIGITS)


def sector_ends(n_checkpoints: int, sectors: int = SECTORS) -> tuple[int, ...]:
    """Checkpoints within a lap (1..N) where each of ``sectors`` sectors ends: as even as the checkpoints allow,
    the last at N. A lap with fewer checkpoints than sectors has one sector per checkpoint."""
    count = max(1, min(sectors, n_checkpoints))
    return tuple(round(n_checkpoints * (j + 1) / count) for j in range(count))


def lap_reports(
    crossings: Sequence[Crossing],
    n_checkpoints: int,
    laps: int,
    n_karts: int,
    finish_times: Sequence[float | None] | None = None,
) -> list[list[LapReport]]:
    """Every kart's completed laps from its checkpoint crossings, with sector times, positions and gaps. A kart's
    last lap ends at its finish (``finish_times``, by kart): off the line where every kart raced the same distance
    from its slot (its wear and speed then those of its last crossing)."""
    ends = sector_ends(n_checkpoints)
    at: dict[tuple[int, int], Crossing] = {(c.kart, c.checkpoint): c for c in crossings}
    for k, finish in enumerate(finish_times or ()):
        last = max((c for c in crossings if c.kart == k), key=lambda c: c.checkpoint, default=None)
        if finish is not None and last is not None:
            at[k, laps * n_checkpoints] = replace(last, checkpoint=laps * n_checkpoints, time=finish)
    leader: dict[int, float] = {}  # lap -> race time the first kart completed it
    order: dict[int, list[float]] = {}
    for lap in range(1, laps + 1):
        times = sorted(at[k, lap * n_checkpoints].time for k in range(n_karts) if (k, lap * n_checkpoints) in at)
        if times:
            leader[lap], order[lap] = times[0], times
    out: list[list[LapReport]] = []
    for k in range(n_karts):
        rows = []
        for lap in range(1, laps + 1):
            end = at.get((k, lap * n_checkpoints))
            if end is None:
                break
            first = (lap - 1) * n_checkpoints
            # times to the millisecond, as in the result: race times rounded first, so sectors add up to laps
            start = _ms(at[k, first].time) if lap > 1 else 0.0
            marks = [start]
            for checkpoint in ends:
                crossing = at.get((k, first + checkpoint))
                marks.append(_ms(crossing.time) if crossing is not None else marks[-1])
            end_time = _ms(end.time)
            rows.append(
                LapReport(
                    lap=lap,
                    time=_ms(end_time - start),
                    sectors=tuple(_ms(b - a) for a, b in itertools.pairwise(marks)),
                    end_time=end_time,
                    position=order[lap].index(end.time) + 1,
                    gap=_ms(end_time - _ms(leader[lap])),
                    wear=end.wear,
                    speed=end.speed,
                )
            )
        out.append(rows)
    return out


def speed_along_lap(
    progress: np.ndarray, speed: np.ndarray, finished: np.ndarray, track_length: float, laps: int, bins: int
) -> list[list[float | None]]:
    """One kart's mean speed [m/s] in each of ``bins`` equal stretches of every lap, from its per-step
    ``progress`` [m] toward the finish, ``speed`` [m/s] and ``finished`` flags (steps after the finish are left
    out). A stretch it never drove through in a lap is ``None``."""
    racing = ~finished
    lap = np.floor(progress[racing] / track_length).astype(np.int64)
    within = progress[racing] - lap * track_length
    column = np.clip((within / track_length * bins).astype(np.int64), 0, bins - 1)
    keep = (lap >= 0) & (lap < laps)
    index = lap[keep] * bins + column[keep]
    sums = np.bincount(index, weights=speed[racing][keep], minlength=laps * bins)
    counts = np.bincount(index, minlength=laps * bins)
    means = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan).reshape(laps, bins)
    return [[None if np.isnan(v) else round(float(v), 3) for v in row] for row in means]


def incident_reports(incidents: Sequence[Incident], timeline: RaceTimeline) -> list[IncidentReport]:
    """The incidents, each with the lap its kart was on."""
    out = []
    for incident in incidents:
        row = min(round(incident.time / timeline.dt), timeline.steps)
        lap = int(timeline.checkpoints_passed[row, incident.kart]) // timeline.n_checkpoints + 1
        out.append(IncidentReport(_ms(incident.time), incident.kart, incident.kind, incident.other, lap))
    return out


def race_report(race_id: str, timeline: RaceTimeline, laps: int) -> RaceReport:
    """The figures of race ``race_id`` (``laps`` laps) from its re-simulated timeline."""
    n_karts, dt = timeline.n_karts, timeline.dt
    laps_by_kart = lap_reports(timeline.crossings, timeline.n_checkpoints, laps, n_karts, timeline.finish_time)
    finishes = [t for t in timeline.finish_time if t is not None]
    winner_time = min(finishes) if finishes else None
    every = max(1, round(WEAR_PERIOD / dt))
    rows = np.arange(0, timeline.steps + 1, every)
    karts = []
    for k in range(n_karts):
        kart_laps = laps_by_kart[k]
        finish = timeline.finish_time[k]
        karts.append(
            KartReport(
                index=k,
                laps=tuple(kart_laps),
                best_lap=min(kart_laps, key=lambda lap: lap.time).lap if kart_laps else None,
                gap_to_winner=finish - winner_time if finish is not None and winner_time is not None else None,
                top_speed=float(np.max(timeline.speed[:, k])) if timeline.steps else 0.0,
                speed_by_lap=tuple(
                    tuple(lap)
                    for lap in speed_along_lap(
                        timeline.progress[:, k],
                        timeline.speed[:, k],
                        timeline.finished[:, k],
                        timeline.track_length,
                        laps,
                        SPEED_BINS,
                    )
                ),
                wear=tuple(round(float(w), 5) for w in timeline.wear[rows, k]),
            )
        )
    bin_width = timeline.track_length / SPEED_BINS
    return RaceReport(
        race_id=race_id,
        laps=laps,
        duration=round(timeline.steps * dt, 6),
        n_checkpoints=timeline.n_checkpoints,
        track_length=timeline.track_length,
        sector_ends=sector_ends(timeline.n_checkpoints),
        distance_bins=tuple(round((j + 0.5) * bin_width, 3) for j in range(SPEED_BINS)),
        wear_times=tuple(round(float(r * dt), 3) for r in rows),
        karts=tuple(karts),
        incidents=tuple(incident_reports(timeline.incidents, timeline)),
        pose_error=timeline.pose_error,
    )
