"""Opponent models and their selection by measured forecast error (controllers.tactical.opponents)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from controllers.parameters import ParameterError
from controllers.race import RaceSpec, run_race
from controllers.racing_line import optimise_racing_line
from controllers.registry import make_agent
from controllers.tactical import rules
from controllers.tactical.calibration import calibrate_tables
from controllers.tactical.game import GameParams, build_tables
from controllers.tactical.opponents import (
    OpponentModelSelector,
    model_names,
    solo_lap_lanes,
)
from controllers.tactical.planner import PlayerState, TacticalPlanner
from sim_core.observation import KartView
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track

TRACK = get_track("oval")
N = TRACK.n_checkpoints
LINE = optimise_racing_line(TRACK, PAPER_KART)
LINE_LANES = LINE.checkpoint_lanes


def _view(passed: int, lane: int) -> KartView:
    """Kart 1 just past its ``passed``-th checkpoint in ``lane``, still in that lane."""
    lateral = float(TRACK.lane_offsets(passed + 1)[lane - 1])
    return KartView(1, 0.0, 0.0, 0.0, 10.0, 0.0, lateral, 0.2, passed, lane, 0, 0.0, 10.0, 0.2, False)


def _drive(selector: OpponentModelSelector, lane_at: Callable[[int], int], checkpoints: int) -> str:
    """Show the selector a kart crossing ``checkpoints`` checkpoints in ``lane_at(c)`` (seen at every crossing);
    the model it plays that kart by at the end."""
    selector.reset(TRACK, LINE_LANES)
    for c in range(1, checkpoints + 1):
        view = _view(c, lane_at(c))
        selector.score([view])
        selector.forecast([view], lambda kart: {})
    return selector.model_of(1).name


def test_the_selector_picks_the_model_that_forecasts_a_known_driver() -> None:
    rng = np.random.default_rng(4)
    own_line = rng.integers(1, TRACK.n_lanes + 1, size=N)  # a lap of its own, driven again and again
    # each driver and the models that forecast it exactly (a lap on, its own last lap forecasts any repeater)
    drivers: list[tuple[Callable[[int], int], set[str]]] = [
        (lambda c: LINE_LANES[c % N], {"racing-line", "own-last-lap"}),
        (lambda c: 1, {"holds-lane", "own-last-lap"}),
        (lambda c: int(own_line[c % N]), {"own-last-lap"}),
    ]
    for lane_at, exact in drivers:
        # every prior, so the choice is the measurement's and not the order's
        for prior in ("racing-line", "holds-lane", "own-last-lap"):
            others = [m for m in ("racing-line", "holds-lane", "own-last-lap") if m != prior]
            selector = OpponentModelSelector.of((prior, *others))
            assert _drive(selector, lane_at, 3 * N) in exact, (exact, prior, selector.errors(1))


def test_a_model_is_kept_until_another_is_better_by_the_margin() -> None:
    selector = OpponentModelSelector.of(("racing-line", "holds-lane"))
    # before any measurement: the prior
    assert _drive(selector, lambda c: 1, 1) == "racing-line"
    # a kart that matches both models as often (the line's lane where it is lane 1, else 1 half the time)
    scores = selector.errors(1)
    assert set(scores) <= {"racing-line", "holds-lane"}


def test_errors_are_the_share_of_missed_lanes() -> None:
    selector = OpponentModelSelector.of(("racing-line", "holds-lane"))
    _drive(selector, lambda c: 1, 4 * N)
    errors = selector.errors(1)
    assert errors["holds-lane"] == pytest.approx(0.0)
    # the line's forecasts miss wherever its lane is not lane 1 (a running mean, so near that share)
    miss = float(np.mean([lane != 1 for lane in LINE_LANES]))
    assert abs(errors["racing-line"] - miss) < 0.35


def test_unknown_models_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match="unknown opponent model 'psychic'"):
        model_names("racing-line+psychic")
    with pytest.raises(ParameterError, match="opponent_models"):  # an agent string: a 422 over REST
        make_agent("mcts-lqng-adaptive:opponent_models=racing-line+psychic")
    with pytest.raises(ValueError):
        model_names("+")
    assert model_names("racing-line+simulated-fixed-lqng") == ("racing-line", "simulated-fixed-lqng")


def test_the_game_plays_held_and_scripted_lanes() -> None:
    tables = calibrate_tables(build_tables(TRACK, PAPER_KART, GameParams()), TRACK, LINE, PAPER_KART)
    script = np.full_like(tables.scripted_lane, -1)
    script[0] = (np.arange(N) % TRACK.n_lanes)[None, :]
    tables = tables._replace(scripted_lane=script)
    moves = np.empty(64, dtype=np.int64)
    bins = len(tables.bin_low)
    for c in range(N):
        state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
        state[:, rules.LANE] = state[:, rules.PREV_LANE] = (0, 2)
        state[:, rules.CHECKPOINT] = c
        state[:, rules.TIME] = state[:, rules.PREV_TIME] = (0, 200)
        state[:, rules.BIN] = 3
        state[1, rules.MODELLED] = rules.MODEL_HOLD
        if rules.legal_moves(tables, state, 1, moves) == 1 and rules.allowed_lane(tables, state, 1) >= 0:
            assert int(moves[0]) // bins == 2  # the lane it holds
        state[1, rules.MODELLED] = rules.MODEL_SCRIPT
        if rules.legal_moves(tables, state, 1, moves) == 1 and rules.allowed_lane(tables, state, 1) >= 0:
            assert int(moves[0]) // bins == (c + 1) % TRACK.n_lanes  # the script's lane at the next checkpoint


def test_the_root_gives_scripted_players_a_script_slot_each() -> None:
    planner = TacticalPlanner(TRACK, PAPER_KART, iterations=10, line=LINE)
    lanes_a = tuple([0] * N)
    lanes_b = tuple([2] * N)
    players = [
        PlayerState(0, 5, 2, 11.0, 0.0, 0.2, 0),
        PlayerState(1, 5, 1, 11.0, 0.1, 0.2, 0, model=rules.MODEL_SCRIPT, script=lanes_a),
        PlayerState(2, 5, 3, 11.0, 0.2, 0.2, 0, model=rules.MODEL_SCRIPT, script=lanes_b),
        PlayerState(3, 5, 4, 11.0, 0.3, 0.2, 0, model=rules.MODEL_HOLD),
    ]
    root, karts = planner.root_state(players, 0)
    codes = {k: int(root[row, rules.MODELLED]) for row, k in enumerate(karts)}
    assert codes[0] == rules.MODEL_FREE and codes[3] == rules.MODEL_HOLD
    slots = {k: codes[k] - rules.MODEL_SCRIPT for k in (1, 2)}
    assert slots[1] != slots[2]
    assert tuple(planner.tables.scripted_lane[slots[1]]) == lanes_a
    assert tuple(planner.tables.scripted_lane[slots[2]]) == lanes_b


def test_a_best_response_forecast_is_the_free_players_own_play() -> None:
    planner = TacticalPlanner(TRACK, PAPER_KART, iterations=10, line=LINE)
    players = [PlayerState(0, 5, 2, 11.0, 0.0, 0.2, 0), PlayerState(1, 5, 3, 11.0, 0.3, 0.2, 0)]
    lanes = planner.best_response_lanes(players, 0, 1)
    assert lanes and min(lanes) == 6 and all(1 <= lane <= TRACK.n_lanes for lane in lanes.values())
    assert planner.best_response_lanes(players, 0, 7) == {}  # not in the game


def test_a_simulated_agent_drives_its_own_lanes() -> None:
    lanes = solo_lap_lanes(TRACK, "fixed-lqng", make_agent)
    assert len(lanes) == N
    # the fixed-line agent follows the racing line it was given: its lanes are the line's nearly everywhere
    assert sum(a == b for a, b in zip(lanes, LINE_LANES, strict=True)) >= 0.8 * N


@pytest.mark.parametrize(("opponent", "chosen"), [("lane-follower", "holds-lane"), ("fixed-lqng", "racing-line")])
def test_in_a_race_the_planner_plays_each_driver_by_what_it_does(opponent: str, chosen: str) -> None:
    # the prior is the wrong model for both drivers: the race's measurements must move it
    prior = "holds-lane" if chosen == "racing-line" else "racing-line"
    other = chosen
    ego = make_agent(f"mcts-lqng-adaptive:iterations=200:opponent_models={prior}+{other}+game")
    spec = RaceSpec(track="oval", controllers=("mcts-lqng-adaptive", opponent), laps=2, seed=5)
    run_race(spec, drivers=[ego, make_agent(opponent)])
    selector = ego.planner.opponents  # type: ignore[attr-defined]
    assert selector.model_of(1).name == chosen, selector.errors(1)
