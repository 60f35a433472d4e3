"""The statistics on small hand-computed cases: the win rule with DNFs, per-agent figures over all races (Δr and
Δv over finished ones), both lane-change counting rules, and the tests against scipy called directly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats as scipy_stats

from arena.original_logs import original_start_lanes
from arena.records import CHECKPOINT, PER_STEP, KartFigures, RaceFigures, winner_index
from arena.report import plot_stem, plot_stems, start_lane_rows
from arena.stats import COMBINED, binomial_win_test, leaderboard, t_test, tournament_stats


def kart(
    agent: str,
    time: float | None,
    faults: int = 0,
    per_step: int = 0,
    checkpoint: int = 0,
    delta_r: float | None = None,
) -> KartFigures:
    return KartFigures(
        agent=agent,
        finished=time is not None,
        total_time=time,
        collisions_at_fault=faults,
        illegal_lane_changes={PER_STEP: per_step, CHECKPOINT: checkpoint},
        safety_rule=PER_STEP,
        passes=1,
        delta_r=delta_r,
        delta_v=None if delta_r is None else 2 * delta_r,
    )


def race(track: str, *karts: KartFigures, lanes: tuple[int, ...] | None = None) -> RaceFigures:
    return RaceFigures(track=track, karts=karts, start_lanes=lanes)


def test_only_a_finisher_can_win_and_the_faster_finisher_wins() -> None:
    assert winner_index((kart("a", 80.0), kart("b", 79.0))) == 1
    assert winner_index((kart("a", 80.0), kart("b", None))) == 0
    assert winner_index((kart("a", None), kart("b", 10.0))) == 1  # a DNF never wins, however far it got
    assert winner_index((kart("a", None), kart("b", None))) is None


def test_win_tables_count_per_track_and_combined_and_skip_races_nobody_won() -> None:
    races = [
        race("oval", kart("a", 80.0), kart("b", 81.0)),
        race("oval", kart("b", 79.0), kart("a", None)),
        race("oval", kart("a", None), kart("b", None)),
        race("complex", kart("a", 90.0), kart("b", None)),
    ]
    stats = tournament_stats(races)
    assert list(stats.tracks) == ["oval", "complex", COMBINED]
    assert stats.tracks["oval"].wins == {"a": {"b": 1}, "b": {"a": 1}}
    assert stats.tracks["complex"].wins == {"a": {"b": 1}, "b": {"a": 0}}
    assert stats.tracks[COMBINED].wins == {"a": {"b": 2}, "b": {"a": 1}}
    oval = stats.tracks["oval"].agent_stats
    assert (oval["a"].races, oval["a"].finished, oval["b"].finished) == (3, 1, 2)


def test_safety_figures_are_over_all_races_and_plan_figures_over_finished_ones() -> None:
    races = [
        race("oval", kart("a", 80.0, faults=1, per_step=2, checkpoint=1, delta_r=1.0), kart("b", 81.0)),
        race("oval", kart("a", None, faults=3, per_step=0, checkpoint=0, delta_r=9.0), kart("b", 81.0)),
        race("oval", kart("a", 70.0, faults=0, per_step=4, checkpoint=2, delta_r=2.0), kart("b", 81.0)),
    ]
    a = tournament_stats(races).tracks["oval"].agent_stats["a"]
    collisions = a.collisions_at_fault
    assert (collisions.mean, collisions.std, collisions.n) == (4 / 3, float(np.std([1, 3, 0])), 3)
    assert collisions.ci95 is not None and (collisions.ci95.low, collisions.ci95.high) == (0.0, 3.0)  # 3 samples
    assert a.illegal_lane_changes.rule == PER_STEP
    assert a.illegal_lane_changes.headline.mean == 2.0
    assert a.illegal_lane_changes.by_rule[CHECKPOINT].mean == 1.0
    assert a.safety_score.mean == pytest.approx((3 + 3 + 4) / 3)
    assert a.safety_score.std == pytest.approx(np.std([3, 3, 4]))  # population deviation, as the paper
    assert a.delta_r is not None and a.delta_r.mean == 1.5 and a.delta_r.n == 2  # the DNF's 9.0 left out
    assert a.delta_v is not None and a.delta_v.mean == 3.0
    assert a.passes is not None and a.passes.mean == 1.0
    entry = tournament_stats(races).to_json()["tracks"]["oval"]["safety"]["a"]
    # three samples: the bootstrap's resampled means run from the smallest value to the largest
    assert entry["illegal_lane_changes"] == {
        "mean": 2.0,
        "std": pytest.approx(np.std([2, 0, 4])),
        "ci95": [0.0, 4.0],
        "rule": PER_STEP,
        PER_STEP: {"mean": 2.0, "std": pytest.approx(np.std([2, 0, 4])), "ci95": [0.0, 4.0]},
        CHECKPOINT: {"mean": 1.0, "std": pytest.approx(np.std([1, 0, 2])), "ci95": [0.0, 2.0]},
    }


def test_the_win_test_is_scipys_binomial_test_among_decided_races() -> None:
    test = binomial_win_test("a", "b", 30, 15)
    assert test.p_value == scipy_stats.binomtest(30, 45, 0.5).pvalue and test.significant
    assert not binomial_win_test("a", "b", 24, 26).significant
    assert binomial_win_test("a", "b", 0, 0).p_value == 1.0


def test_the_metric_test_is_scipys_pooled_two_sided_t_test() -> None:
    rng = np.random.default_rng(0)
    x, y = rng.poisson(1.0, 60).astype(float), rng.poisson(1.6, 50).astype(float)
    test = t_test("a", "b", list(x), list(y))
    assert test is not None
    expected = scipy_stats.ttest_ind(x, y, equal_var=True)
    assert (test.statistic, test.p_value) == (pytest.approx(expected.statistic), pytest.approx(expected.pvalue))
    assert t_test("a", "b", [1.0], [1.0, 2.0]) is None
    same = t_test("a", "b", [0.0, 0.0], [0.0, 0.0, 0.0])
    assert same is not None and same.p_value == 1.0 and not same.significant
    apart = t_test("a", "b", [1.0, 1.0], [0.0, 0.0])
    assert apart is not None and apart.significant and math.isinf(apart.statistic)


def test_an_agent_is_marked_only_when_it_differs_from_every_other_agent() -> None:
    races = []
    for i in range(30):
        races.append(race("oval", kart("low", 80.0, faults=0), kart("mid", 81.0, faults=2 + i % 2)))
        races.append(race("oval", kart("high", 80.0, faults=2 + (i + 1) % 2), kart("low", 81.0, faults=0)))
    table = tournament_stats(races).tracks["oval"]
    assert table.marked("collisions_at_fault", "low")
    assert not table.marked("collisions_at_fault", "mid") and not table.marked("collisions_at_fault", "high")
    marks = table.to_json()["tests"]["marks"]["metrics"]
    assert marks["low"]["collisions_at_fault"] and not marks["mid"]["collisions_at_fault"]


def test_the_leaderboard_counts_races_wins_and_safety_across_tournaments_and_ranks_them() -> None:
    first = [
        race("oval", kart("a", 80.0, faults=1), kart("b", 81.0)),  # a wins
        race("oval", kart("a", None), kart("b", None, per_step=3)),  # nobody wins
    ]
    second = [
        race("complex", kart("c", 90.0), kart("a", 91.0, per_step=1, checkpoint=5)),  # c wins
        race("complex", kart("b", 70.0), kart("c", 75.0)),  # b wins
    ]
    board = {s.agent: s for s in leaderboard([first, second])}
    a, b, c = board["a"], board["b"], board["c"]
    assert (a.tournaments, a.races, a.wins, a.finished) == (2, 3, 1, 2)
    assert a.win_rate == pytest.approx(1 / 3)
    assert (a.safety_score.mean, a.safety_score.n) == (pytest.approx(2 / 3), 3)  # 1, 0, 1 (the per-step rule)
    assert (b.tournaments, b.races, b.wins, b.finished, b.win_rate) == (2, 3, 1, 2, pytest.approx(1 / 3))
    assert b.safety_score.mean == 1.0  # 0, 3, 0
    assert (c.tournaments, c.races, c.wins, c.finished, c.win_rate) == (1, 2, 1, 2, 0.5)
    # c's win rate first; a and b tie on win rate and wins: the lower safety score first
    assert [s.agent for s in leaderboard([first, second])] == ["c", "a", "b"]
    assert leaderboard([]) == []


def test_plot_file_names_are_safe_for_any_track_name() -> None:
    assert plot_stem("wins", "oval") == "wins_oval"
    assert plot_stem("safety", "tracks/my track.json") == "safety_tracks_my_track_json"
    stats = tournament_stats([race("oval", kart("a", 80.0), kart("b", None))])
    assert plot_stems(stats) == ["wins_oval", "safety_oval", "wins_combined", "safety_combined", "finish_times"]


def test_wins_by_start_lane_count_each_lane_and_pair_and_test_the_lanes_effect_with_fishers_exact_test() -> None:
    races = [
        race("oval", kart("a", 80.0), kart("b", 81.0), lanes=(2, 3)),  # a from 2 wins
        race("oval", kart("a", 80.0), kart("b", 81.0), lanes=(2, 3)),  # a from 2 wins
        race("oval", kart("b", 80.0), kart("a", 81.0), lanes=(2, 3)),  # b from 2 wins: a from 3 loses
        race("oval", kart("a", 79.0), kart("b", 80.0), lanes=(3, 2)),  # a from 3 wins
        race("oval", kart("a", None), kart("b", None), lanes=(3, 2)),  # nobody won: counted, neither side
        race("oval", kart("a", 70.0), kart("b", 90.0)),  # start lanes unknown: left out
        race("oval", kart("a", 80.0), kart("a", 81.0), lanes=(2, 3)),  # self-play: per lane only
    ]
    table = tournament_stats(races).tracks["oval"]
    lanes = table.start_lanes
    assert lanes.races == 6
    as_tuples = {lane: (r.races, r.wins, r.losses) for lane, r in lanes.by_lane.items()}
    assert as_tuples == {2: (6, 4, 1), 3: (6, 1, 4)}
    a_vs_b = lanes.pairs[("a", "b")]
    assert {lane: (r.races, r.wins, r.losses) for lane, r in a_vs_b.by_lane.items()} == {2: (2, 2, 0), 3: (3, 1, 1)}
    assert a_vs_b.fisher_p == pytest.approx(scipy_stats.fisher_exact([[2, 0], [1, 1]]).pvalue)
    b_vs_a = lanes.pairs[("b", "a")]
    assert {lane: (r.races, r.wins, r.losses) for lane, r in b_vs_a.by_lane.items()} == {2: (3, 1, 1), 3: (2, 0, 2)}
    assert list(lanes.pairs) == [("a", "b"), ("b", "a")]
    data = table.to_json()["start_lanes"]
    assert data["pairs"]["a"]["b"] == {
        "by_lane": {"2": {"races": 2, "wins": 2, "losses": 0}, "3": {"races": 3, "wins": 1, "losses": 1}},
        "fisher_p": a_vs_b.fisher_p,
        "significant": False,
    }
    rows = start_lane_rows(table)
    assert rows[1:] == [["a vs b", "2–0", "1–1", "1"], ["any kart", "4–1", "1–4", "-"]]


def test_a_lane_effect_is_marked_significant_and_one_lane_has_no_test() -> None:
    decided = [race("oval", kart("a", 80.0), kart("b", 81.0), lanes=(2, 3)) for _ in range(6)]
    decided += [race("oval", kart("a", 82.0), kart("b", 81.0), lanes=(3, 2)) for _ in range(6)]
    split = tournament_stats(decided).tracks["oval"].start_lanes.pairs[("a", "b")]
    assert split.fisher_p == pytest.approx(scipy_stats.fisher_exact([[6, 0], [0, 6]]).pvalue) and split.fisher_p < 0.05
    assert start_lane_rows(tournament_stats(decided).tracks["oval"])[1][-1].endswith("*")
    one_lane = tournament_stats(decided[:6]).tracks["oval"].start_lanes.pairs[("a", "b")]
    assert one_lane.fisher_p is None and list(one_lane.by_lane) == [2]
    assert tournament_stats([race("oval", kart("a", 1.0), kart("b", 2.0))]).tracks["oval"].start_lanes.races == 0


def test_the_originals_grid_puts_the_first_listed_kart_in_lane_2_in_even_races() -> None:
    assert [original_start_lanes(n, 2) for n in range(4)] == [(2, 3), (3, 2), (2, 3), (3, 2)]
    # three karts: the permutations of (0, 1, 2) in lexicographic order place karts into lanes 2, 3, 2
    assert original_start_lanes(0, 3) == (2, 3, 2)
    assert original_start_lanes(1, 3) == (2, 2, 3)  # order (0, 2, 1)
    assert original_start_lanes(2, 3) == (3, 2, 2)  # order (1, 0, 2)
    assert original_start_lanes(6, 3) == original_start_lanes(0, 3)
    with pytest.raises(ValueError, match="4 places"):
        original_start_lanes(0, 5)
