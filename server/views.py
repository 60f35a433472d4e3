"""What the API answers, one builder per resource, from the typed records: a :class:`~server.snapshot.RaceSnapshot`
(a live or a stored race alike), a :class:`~server.results.RaceRecord` (a result) and tick statistics."""

from __future__ import annotations

from dataclasses import asdict

from server.models import (
    CreatedKartOut,
    DriverStatusOut,
    KartOut,
    RaceCreatedOut,
    RaceDetailOut,
    RaceSummaryOut,
    ResultOut,
    StandingOut,
    TicksOut,
    TickStatsOut,
)
from server.race_config import KartEntry
from server.results import TIME_DIGITS, RaceRecord
from server.snapshot import DriverState, RaceSnapshot, Standing
from server.status import RaceStatus
from server.ticks import TickSummary


def viewer_url(
    race_id: str,
    viewer: bool,
    status: RaceStatus = RaceStatus.STARTING,
    recorded: bool = False,
    open_now: bool = True,
) -> str | None:
    """The race's 3D view page: the live view while the race is live and its scene is open (``open_now``; a new
    race's opens shortly), its replay player once it is over and recorded; None when the server runs without 3D
    views (``viewer`` false), while a live race has no scene open, or for a race over with nothing recorded."""
    if not viewer:
        return None
    if status.live:
        return f"/races/{race_id}/viewer/" if open_now else None
    return f"/races/{race_id}/replay/" if recorded else None


def page_url(race_id: str) -> str:
    """The race's page."""
    return f"/races/{race_id}"


def telemetry_url(race_id: str) -> str:
    """The race's telemetry websocket."""
    return f"/api/races/{race_id}/telemetry"


def kart_view(kart: KartEntry) -> KartOut:
    """A kart of a race."""
    return KartOut(
        index=kart.index, name=kart.name, controller=kart.controller, params=dict(kart.params), team=kart.team
    )


def created_view(snapshot: RaceSnapshot, tokens: dict[int, str], viewer: bool) -> RaceCreatedOut:
    """A just-created race, with the drive tokens of its human karts (``tokens``, by kart index)."""
    race_id = snapshot.id
    karts = []
    for kart in snapshot.karts:
        token = tokens.get(kart.index)
        drive = f"/races/{race_id}/drive?kart={kart.index}&token={token}" if token is not None else None
        karts.append(CreatedKartOut(**kart_view(kart).model_dump(), drive_url=drive))
    return RaceCreatedOut(
        id=race_id,
        status=snapshot.status,
        track=snapshot.track,
        laps=snapshot.laps,
        seed=snapshot.seed,
        kart_preset=snapshot.kart_preset,
        karts=karts,
        viewer_url=viewer_url(race_id, viewer),
        telemetry_url=telemetry_url(race_id),
        drive_tokens={str(k): token for k, token in tokens.items()},
    )


def standing_view(standing: Standing) -> StandingOut:
    """One kart's place in the running order (times to the millisecond)."""
    finish = round(standing.finish_time, TIME_DIGITS) if standing.finish_time is not None else None
    return StandingOut(**{**asdict(standing), "finish_time": finish})


def driver_view(driver: DriverState) -> DriverStatusOut:
    """A kart's driver and its faults."""
    faults = driver.faults
    return DriverStatusOut(
        index=driver.kart.index,
        name=driver.kart.name,
        controller=driver.kart.controller,
        controller_faults=faults.controller_faults,
        exceptions=faults.exceptions,
        hangs=faults.hangs,
        missed_deadlines=faults.missed_deadlines,
        planner_faults=faults.planner_faults,
        worker_restarts=faults.worker_restarts,
        plans_applied=faults.plans_applied,
        disabled=faults.disabled,
        braking=driver.braking,
        driver_connected=driver.driver_connected,
        last_error=faults.last_error,
    )


def tick_stats_view(stats: TickSummary | None) -> TickStatsOut | None:
    """Tick timing (None before the first tick)."""
    return TickStatsOut(**asdict(stats)) if stats is not None else None


def summary_view(snapshot: RaceSnapshot) -> RaceSummaryOut:
    """A race in a listing."""
    return RaceSummaryOut(
        id=snapshot.id,
        status=snapshot.status,
        track=snapshot.track,
        laps=snapshot.laps,
        created_at=snapshot.created_at,
        time=round(snapshot.time, TIME_DIGITS),
        karts=[kart_view(k) for k in snapshot.karts],
        standings=[standing_view(s) for s in snapshot.standings],
        winner=snapshot.winner,
    )


def detail_view(snapshot: RaceSnapshot, viewer: bool, viewer_open: bool) -> RaceDetailOut:
    """A race in full; ``viewer``: this server opens 3D views; ``viewer_open``: the race's live view is open now."""
    race_id = snapshot.id
    return RaceDetailOut(
        **summary_view(snapshot).model_dump(),
        seed=snapshot.seed,
        kart_preset=snapshot.kart_preset,
        start_lanes=list(snapshot.start_lanes),
        step=snapshot.step,
        drivers=[driver_view(d) for d in snapshot.drivers],
        tick_stats=tick_stats_view(snapshot.tick_stats),
        viewer_url=viewer_url(race_id, viewer, snapshot.status, snapshot.recorded, viewer_open),
        page_url=page_url(race_id),
        telemetry_url=telemetry_url(race_id),
        result_url=f"/api/races/{race_id}/result",
        replay_url=f"/api/races/{race_id}/replay",
        report_url=f"/api/races/{race_id}/report",
        error=snapshot.error,
    )


def ticks_view(race_id: str, stats: TickSummary | None, recent_jitter_ms: list[float]) -> TicksOut:
    """Tick timing with the raw jitter of the last ticks."""
    return TicksOut(race_id=race_id, stats=tick_stats_view(stats), recent_jitter_ms=recent_jitter_ms)


def result_view(record: RaceRecord) -> ResultOut:
    """A race's result."""
    return ResultOut.model_validate(record.to_json())
