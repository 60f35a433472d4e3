"""The tactical planner in traffic: the collision window along a section, the line-following opponent model,
line-calibrated segment times, no plan collapse in a 4-kart race, passes of slower karts, and races where each of
the LQ tracker's traffic rules is what keeps mcts-lqng out of a collision (the same race without it collides)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from controllers.base import Controller
from controllers.hierarchical import HierarchicalController
from controllers.lq.tracker import LQNGTracker
from controllers.lq.traffic import AlongsideDiscipline, StationKeeping, Yield
from controllers.race import RaceSpec, run_race
from controllers.race_metrics import RaceMetrics
from controllers.racing_line import optimise_racing_line
from controllers.registry import make_controller
from controllers.rl.agents import E2EController
from controllers.rl.filters import RecoverFromStall
from controllers.tactical import rules
from controllers.tactical.calibration import calibrate_tables
from controllers.tactical.game import GameParams, build_tables
from sim_core.conditions import ConditionSet
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track

TRACK = get_track("oval")
LINE = optimise_racing_line(TRACK, PAPER_KART)
TABLES = calibrate_tables(build_tables(TRACK, PAPER_KART, GameParams()), TRACK, LINE, PAPER_KART)


def spread_start(spread: float) -> ConditionSet:
    """The paper's conditions but launches spread over [0, ``spread``) s (the races these scenarios came from)."""
    return ConditionSet(f"spread-{spread}", start_spread=spread)


def _state(lanes: tuple[int, int], checkpoints: tuple[int, int], times: tuple[int, int]) -> np.ndarray:
    state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
    state[:, rules.LANE] = lanes
    state[:, rules.PREV_LANE] = lanes
    state[:, rules.CHECKPOINT] = checkpoints
    state[:, rules.TIME] = times
    state[:, rules.PREV_TIME] = times
    state[:, rules.BIN] = 5
    return state


def test_a_follower_may_not_arrive_within_a_kart_length_behind_in_the_same_lane() -> None:
    # player 1 drove checkpoint 0 -> 1 in lane 2 (0-based 1) slowly, from t = 0.00 to 1.40 s; player 0 follows 0.45 s
    # later, faster
    state = _state((1, 1), (0, 1), (45, 140))
    state[1, rules.PREV_TIME] = 0
    bins = len(TABLES.bin_low)
    legal = 0
    for vbin in range(bins):
        arrival, _, ok = rules.move_outcome(TABLES, state, 0, 1, vbin)
        speed = TABLES.distance[0, 0, 0] / ((arrival - 45) / 100.0) if ok else 0.0
        if ok:
            legal += 1
            # legal only when the gap at the checkpoint (and along the section) is at least the distance window
            assert (arrival - 140) / 100.0 * speed >= TABLES.collision_distance - 1e-6
    assert legal < bins  # the fast bins, catching up within a kart length, are ruled out
    # a lane away is always free of it
    assert any(rules.move_outcome(TABLES, state, 0, 3, vbin)[2] for vbin in range(bins))


def test_a_leader_need_not_yield_to_a_kart_behind_but_may_not_cut_across_one_alongside() -> None:
    bins = len(TABLES.bin_low)
    # player 0 leads player 1 (lane 3, 0-based 2) by 0.5 s: it may take player 1's lane
    behind = _state((1, 2), (0, 0), (0, 50))
    assert any(rules.move_outcome(TABLES, behind, 0, 2, vbin)[2] for vbin in range(bins))
    # side by side (0.05 s apart): it may not
    alongside = _state((1, 2), (0, 0), (0, 5))
    assert not any(rules.move_outcome(TABLES, alongside, 0, 2, vbin)[2] for vbin in range(bins))


def test_a_modelled_player_follows_the_racing_line_at_its_best_speed() -> None:
    moves = np.empty(64, dtype=np.int64)
    for c in range(TRACK.n_checkpoints):
        state = _state((1, 2), (c, c), (0, 200))
        state[1, rules.MODELLED] = 1
        count = rules.legal_moves(TABLES, state, 1, moves)
        assert count == 1
        lane, _ = divmod(int(moves[0]), len(TABLES.bin_low))
        assert lane + 1 == LINE.checkpoint_lanes[(c + 1) % TRACK.n_checkpoints]
        # an unmodelled player keeps every choice
        assert rules.legal_moves(TABLES, _state((1, 2), (c, c), (0, 200)), 1, moves) > 1


def test_the_racing_line_is_the_cheapest_way_through_the_calibrated_game() -> None:
    n = TRACK.n_checkpoints
    cheapest = 0
    for c in range(n):
        here, there = LINE.checkpoint_lanes[c] - 1, LINE.checkpoint_lanes[(c + 1) % n] - 1
        cheapest += int(TABLES.penalty[c, here, there] <= TABLES.penalty[c].min() + 1.0)  # within 0.01 s
    assert cheapest >= 0.9 * n


def test_four_kart_race_plans_never_collapse() -> None:
    names = ("mcts-lqng", "fixed-lqng", "mcts-lqng", "fixed-lqng")
    metrics = RaceMetrics(len(names))
    outcome = run_race(RaceSpec(track="oval", controllers=names, laps=1, seed=3), on_step=metrics)
    assert all(k.finished for k in outcome.result.karts)
    horizon = GameParams().horizon
    assert set(metrics.shortest_plan) == {0, 2}
    assert min(metrics.shortest_plan.values()) >= horizon, metrics.shortest_plan


# the leader on pole in lane 2, the ego in lane 3 this far behind it: a kart at a pace handicap is also slower off
# the line, so from a side-by-side grid the ego would lead from the first corner and never have to pass
BEHIND = ConditionSet("ego-behind", grid="staggered", stagger=8.0)


def _pass_a_slower_kart(pace: float, seed: int, laps: int, **overrides: object) -> None:
    """mcts-lqng (with its parameters ``overrides``) from 8 m behind fixed-lqng at ``pace`` on complex: it must
    pass, win, and break no rule."""
    agents = ("mcts-lqng", f"fixed-lqng@{pace}")
    spec = RaceSpec(track="complex", controllers=agents, laps=laps, seed=seed, start_lanes=(3, 2), conditions=BEHIND)
    drivers = [make_controller("mcts-lqng", **overrides), make_controller("fixed-lqng")]
    tactical, slow = run_race(spec, drivers=drivers).result.karts
    assert tactical.passes >= 1
    assert tactical.finish_time is not None and slow.finish_time is not None
    assert tactical.finish_time < slow.finish_time
    assert tactical.collisions_at_fault == 0 and tactical.illegal_lane_changes == 0


@pytest.mark.parametrize("pace", [0.85, 0.9])
def test_a_faster_tactical_kart_passes_a_slower_one_by_the_rules(pace: float) -> None:
    """Started 8 m behind a line follower at a pace handicap of 0.85 or 0.9, mcts-lqng must get past it and win,
    with no collision at fault and no illegal lane change."""
    _pass_a_slower_kart(pace, seed=0, laps=2)


@pytest.mark.parametrize("seed", [2, 4, 14])
def test_a_pass_under_way_is_finished_against_a_kart_7_percent_slower(seed: int) -> None:
    """The same start against a kart at pace 0.93, 2 laps: mcts-lqng must get by, win, and break
    no rule. What it takes: ``hold_gain_s`` keeps a pass under way when the next plan prefers the line, and the
    pass detector drives the passing lane exactly (blended toward the line it stayed in the other kart's wake, held
    back by station keeping), also where the kart ahead is predicted to leave the ego's lane."""
    _pass_a_slower_kart(0.93, seed=seed, laps=2)


@pytest.mark.parametrize("seed", [0, 6])
def test_following_closely_sets_up_the_pass_of_a_kart_7_percent_slower_over_3_laps(seed: int) -> None:
    """The paper's 3 laps from 8 m behind a kart at pace 0.93: following closely (Gipps' safe
    speed, a 2.3 m standoff on straights) mcts-lqng closes up, dives inside and wins, breaking no rule (a linear
    station-keeping rule kept it 5 m back on the straights and it followed the kart home from these seeds)."""
    _pass_a_slower_kart(0.93, seed=seed, laps=3)


@pytest.mark.parametrize(("seed", "lanes"), [(615434538, (2, 3)), (1889878166, (2, 3))])
def test_behind_a_faster_kart_it_makes_no_illegal_lane_change(seed: int, lanes: tuple[int, int]) -> None:
    """Two races on the oval: behind mcts-rl or e2e, a tracker that drove a lane a few metres behind the faster
    kart exactly, as if passing, crossed a lane boundary early on the straight before a curve: one illegal lane
    change each. Only a kart slower than the racing line is passed in a lane driven exactly."""
    leader = "mcts-rl" if seed == 615434538 else "e2e"
    spec = RaceSpec(track="oval", controllers=(leader, "mcts-lqng"), seed=seed, start_lanes=lanes)
    faster, tactical = run_race(spec).result.karts
    assert faster.finish_time is not None and tactical.finish_time is not None
    assert faster.finish_time < tactical.finish_time
    assert tactical.illegal_lane_changes == 0


@pytest.mark.parametrize(
    ("track", "seed", "spread"), [("complex", 60, 0.5), ("complex", 80, 0.5), ("complex-reversed", 58, 0.25)]
)
def test_from_a_spread_start_it_spends_no_more_lane_changes_than_the_rule_allows(
    track: str, seed: int, spread: float
) -> None:
    """Races from a spread start, mcts-lqng from lane 2. On complex, with its four lane changes of the back
    straight spent, a tracker that blended toward the next curve's lane crossed into it a few metres before the
    curve began: one illegal lane change each. The lane-rule guard keeps the kart in reach of its lanes
    until the curve; a guard that held the aim in the lane outright made it turn into complex-reversed's first
    hairpin late, into the kart beside it (a collision at fault)."""
    spec = RaceSpec(
        track=track,
        controllers=("mcts-lqng", "fixed-lqng"),
        seed=seed,
        start_lanes=(2, 3),
        conditions=spread_start(spread),
    )
    tactical, line = run_race(spec).result.karts
    assert tactical.finish_time is not None and line.finish_time is not None
    assert tactical.illegal_lane_changes == 0 and tactical.collisions_at_fault == 0


def _race_with_tracker(spec: RaceSpec, opponent: str | Controller, change: Any = None) -> list[int]:
    """Collisions at fault of mcts-lqng (kart 0, its traffic rules changed by ``change``: rules -> rules) and of
    ``opponent`` (a registered name, or a driver) in the race ``spec``."""
    driver = make_controller("mcts-lqng")
    assert isinstance(driver, HierarchicalController) and isinstance(driver.tracker, LQNGTracker)
    if change is not None:
        driver.tracker = LQNGTracker(driver.tracker.params, change(driver.tracker.rules))
    other = make_controller(opponent) if isinstance(opponent, str) else opponent
    karts = run_race(spec, drivers=[driver, other]).result.karts
    assert all(k.finish_time is not None for k in karts)
    return [k.collisions_at_fault for k in karts]


def _without(kind: type) -> Any:
    """A change of the rules that drops those of type ``kind``."""
    return lambda rules: tuple(r for r in rules if not isinstance(r, kind))


def test_alongside_in_a_curve_it_does_not_steer_into_the_kart_beside_it() -> None:
    """complex-reversed from a spread start (seed 13, launches up to 0.25 s apart), mcts-lqng from lane 3: it draws
    alongside fixed-lqng on the inside of the curve at checkpoint 10, and without the alongside discipline its line
    out of the curve closes on the other kart, a collision at fault by the alongside rule. With it, it steers for no
    offset nearer that kart than 1.5 m."""
    spec = RaceSpec(
        track="complex-reversed",
        controllers=("mcts-lqng", "fixed-lqng"),
        seed=13,
        start_lanes=(3, 2),
        conditions=spread_start(0.25),
    )
    assert _race_with_tracker(spec, "fixed-lqng")[0] == 0
    assert _race_with_tracker(spec, "fixed-lqng", _without(AlongsideDiscipline))[0] == 1


def test_it_keeps_station_behind_a_kart_drifting_into_its_path() -> None:
    """A lane-2 start on the oval against the paper's e2e, without traffic rules (seed 2): following closely,
    1.7 m behind e2e and 1.5 m aside, its nose beside e2e's tail, e2e drifts across it. Counting a kart ahead that
    will be in its path within 0.4 s as in its path, it drops back in time; with no prediction (station keeping's
    and the yield's) it collides, at fault as the follower."""
    spec = RaceSpec(track="oval", controllers=("mcts-lqng", "e2e"), seed=2, start_lanes=(2, 3))

    def drifting() -> Controller:  # the paper's E2E: the policy and its stall recovery, no traffic rules of its own
        return E2EController(filters=(RecoverFromStall(),))

    assert _race_with_tracker(spec, drifting())[0] == 0

    def no_prediction(rules: tuple[Any, ...]) -> tuple[Any, ...]:
        return tuple(
            replace(r, predict_time=0.0) if isinstance(r, StationKeeping) else r for r in _without(Yield)(rules)
        )

    assert _race_with_tracker(spec, drifting(), no_prediction)[0] == 1
