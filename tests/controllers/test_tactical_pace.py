"""The pace model of the tactical game: each kart's measured pace (hand-worked sums over the line's section
times), which stretches count (clean air, past the start), and what a pace does to the game's arrivals."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.racing_line import optimise_racing_line
from controllers.tactical import rules
from controllers.tactical.game import GameParams, build_tables
from controllers.tactical.pace import PACE_RANGE, PaceMeter, line_section_times
from controllers.tactical.planner import PlayerState, TacticalPlanner
from sim_core.observation import KartView
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track

TRACK = get_track("oval")
LINE = optimise_racing_line(TRACK, PAPER_KART)


def _kart(index: int, checkpoints: int, crossing_time: float, progress: float) -> KartView:
    """A kart with ``checkpoints`` passed, the last at ``crossing_time``, now at ``progress`` [m]."""
    return KartView(
        index, 0.0, 0.0, 0.0, 12.0, progress, 0.0, 0.25, checkpoints, 2, 0, crossing_time, 12.0, 0.25, False
    )


def test_the_line_section_times_add_up_to_the_lines_lap() -> None:
    times = line_section_times(TRACK, LINE)
    assert times.shape == (TRACK.n_checkpoints,)
    assert np.all(times > 0.0)
    assert times.sum() == pytest.approx(LINE.lap_time, rel=0.01)


def test_pace_is_observed_time_over_the_lines_time_with_old_stretches_forgotten() -> None:
    """Two stretches of a lone kart, 10 % and then 30 % over the line: the pace is the memory-weighted ratio
    (0.5 here), worked by hand from the line's section times."""
    meter = PaceMeter(np.full(TRACK.n_checkpoints, 1.0), memory=0.5, min_seconds=0.0)
    meter.observe((_kart(0, 5, 10.0, 50.0),), TRACK)
    assert meter.pace(0, fallback=0.97) == 0.97  # nothing counted yet
    meter.observe((_kart(0, 7, 12.2, 70.0),), TRACK)  # sections 5, 6: 2 s of line, 2.2 s observed
    assert meter.pace(0, fallback=0.97) == pytest.approx(1.1)
    meter.observe((_kart(0, 8, 13.5, 80.0),), TRACK)  # section 7: 1 s of line, 1.3 s observed
    assert meter.pace(0, fallback=0.97) == pytest.approx((0.5 * 2.2 + 1.3) / (0.5 * 2.0 + 1.0))


def test_stretches_in_traffic_at_the_start_or_before_enough_time_do_not_count() -> None:
    section = np.full(TRACK.n_checkpoints, 1.0)
    # a kart 10 m ahead at either end of the stretch: held up, not its pace
    meter = PaceMeter(section, min_seconds=0.0)
    meter.observe((_kart(0, 5, 10.0, 50.0), _kart(1, 6, 9.5, 60.0)), TRACK)
    meter.observe((_kart(0, 7, 13.0, 70.0), _kart(1, 8, 12.0, 90.0)), TRACK)  # clean now, not before
    assert meter.pace(0, fallback=1.0) == 1.0
    assert meter.pace(1, fallback=1.0) == pytest.approx(2.5 / 2.0)  # the leader is in clean air throughout
    # the standing start (checkpoints before skip_checkpoints)
    meter = PaceMeter(section, min_seconds=0.0)
    meter.observe((_kart(0, 1, 1.0, 10.0),), TRACK)
    meter.observe((_kart(0, 3, 5.0, 30.0),), TRACK)
    assert meter.pace(0, fallback=1.0) == 1.0
    # under min_seconds of line time counted: the fallback
    meter = PaceMeter(section, min_seconds=3.0)
    meter.observe((_kart(0, 5, 10.0, 50.0),), TRACK)
    meter.observe((_kart(0, 7, 12.2, 70.0),), TRACK)
    assert meter.pace(0, fallback=1.0) == 1.0
    # a spin is not a pace
    meter = PaceMeter(section, min_seconds=0.0)
    meter.observe((_kart(0, 5, 10.0, 50.0),), TRACK)
    meter.observe((_kart(0, 6, 20.0, 60.0),), TRACK)
    assert meter.pace(0, fallback=1.0) == PACE_RANGE[1]


def test_a_players_pace_scales_its_section_times_in_the_game() -> None:
    """The same move at pace 1.1 takes 1.1 times as long (section time and lane penalty), to the 0.01 s unit;
    an unset pace (0) is the game's model (1)."""
    tables = build_tables(TRACK, PAPER_KART, GameParams())
    state = np.zeros((1, rules.N_FIELDS), dtype=np.int64)
    state[0, rules.CHECKPOINT] = 3
    state[0, rules.LANE] = state[0, rules.PREV_LANE] = 1
    state[0, rules.BIN] = 5
    state[0, rules.WEAR] = 2500
    base, _, ok = rules.move_outcome(tables, state, 0, 1, 5)
    assert ok and base > 0
    state[0, rules.PACE] = rules.PACE_UNITS
    assert rules.move_outcome(tables, state, 0, 1, 5)[0] == base
    state[0, rules.PACE] = round(1.1 * rules.PACE_UNITS)
    slower = rules.move_outcome(tables, state, 0, 1, 5)[0]
    assert abs(slower - 1.1 * base) <= 1.0


def test_the_games_forecast_of_an_opponent_takes_its_pace() -> None:
    """A line follower 0.3 s ahead on the oval: forecast 6 % later at the horizon at pace 1.06 than at pace 1
    (nobody ahead of it to hold it up), while the ego behind it is forecast later too (it cannot pass within
    the horizon at that pace)."""
    line = LINE
    lanes = line.checkpoint_lanes
    n = TRACK.n_checkpoints
    speed = float(line.speed_at(float(TRACK.checkpoint_s[10 % n])))
    forecast = {}
    for pace in (1.0, 1.06):
        me = PlayerState(0, 10, lanes[10], speed, 0.3, 0.25, 0)
        other = PlayerState(1, 10, lanes[10], speed, 0.0, 0.25, 0, model=rules.MODEL_LINE, pace=pace)
        planner = TacticalPlanner(TRACK, PAPER_KART, iterations=2000, seed=1, line=line, deviation_gain=0.1)
        plan = planner.plan([me, other], 0)
        forecast[pace] = (plan.ego_waypoints[-1].time, plan.opponent_waypoints()[1][-1].time)
    assert forecast[1.06][1] == pytest.approx(1.06 * forecast[1.0][1], rel=0.01)
    assert forecast[1.06][0] > forecast[1.0][0]


def test_in_a_race_the_planner_measures_the_faster_kart_faster() -> None:
    """mcts-rl (pace model on by default) leading fixed-lqng on complex for 40 s: both karts have a measured
    pace by then, mcts-rl's own under fixed-lqng's (it laps 3 s a race faster alone), and the game's players
    carry them; with the model off every pace is 1."""
    from controllers.hierarchical import HierarchicalController
    from controllers.race import RaceSpec, run_race
    from controllers.tactical.high_level import MCTSPlanner

    seen: dict[str, float] = {}

    def hook(world, drivers, step) -> None:  # type: ignore[no-untyped-def]
        driver = drivers[0]
        assert isinstance(driver, HierarchicalController) and isinstance(driver.planner, MCTSPlanner)
        seen["mine"], seen["theirs"] = driver.planner.pace_of(0, 0), driver.planner.pace_of(1, 0)

    spec = RaceSpec(track="complex", controllers=("mcts-rl", "fixed-lqng"), seed=1, start_lanes=(3, 2), time_limit=40)
    run_race(spec, on_step=hook)
    assert 0.95 < seen["mine"] < seen["theirs"] < 1.2
    off = MCTSPlanner(pace_model=False)
    assert off.pace_of(0, 0) == off.pace_of(1, 0) == 1.0
