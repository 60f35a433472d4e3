"""The MCTS tactical planner: search quality against exhaustive solutions, rule-abiding plans, determinism."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.racing_line import RacingLine, optimise_racing_line
from controllers.tactical import rules
from controllers.tactical.exact import optimal_first_moves, random_small_games
from controllers.tactical.game import GameParams
from controllers.tactical.mcts import SearchTree
from controllers.tactical.planner import (
    DEFAULT_EXPLORATION,
    DEFAULT_GREEDY,
    HOLD_MARGIN,
    PlayerState,
    TacticalPlanner,
    _advantage,
)
from sim_core.params import PAPER_KART
from sim_core.rules import lane_change_update
from sim_core.track import Track
from sim_core.track_io import get_track

TRACKS = {name: get_track(name) for name in ("oval", "complex")}


def test_large_budget_finds_the_exact_best_first_move() -> None:
    games = random_small_games(200)
    hits = 0
    for tb, state in games:
        _, best, _ = optimal_first_moves(tb, state, horizon=2)
        tree = SearchTree(20_001, 2, 64)
        tree.run(tb, state, 2, 20_000, 1, DEFAULT_EXPLORATION, DEFAULT_GREEDY)
        pick = max(tree.children(0), key=lambda c: tree.visits[c])
        hits += int(tree.action[pick]) in best
    assert hits / len(games) >= 0.9, f"exact best first move in {hits} of {len(games)} states"


def players_from(rng: np.random.Generator, track, n_players: int) -> list[PlayerState]:
    base = int(rng.integers(0, 3 * track.n_checkpoints))
    players = []
    for k in range(n_players):
        players.append(
            PlayerState(
                kart=k,
                checkpoint=base + int(rng.integers(0, 2)),
                lane=int(rng.integers(1, 5)),
                speed=float(rng.uniform(5.0, 15.0)),
                time=float(rng.uniform(0.0, 1.0)),
                wear=float(rng.uniform(0.0, 0.6)),
                lane_changes=int(rng.integers(0, track.lane_change_limit + 1)),
            )
        )
    return players


@settings(max_examples=40)
@given(seed=hs.integers(0, 2**31 - 1), track_name=hs.sampled_from(sorted(TRACKS)), n_players=hs.integers(1, 3))
def test_plans_never_break_a_rule(seed: int, track_name: str, n_players: int) -> None:
    track = TRACKS[track_name]
    rng = np.random.default_rng(seed)
    planner = TacticalPlanner(track, PAPER_KART, iterations=300, seed=seed)
    players = players_from(rng, track, n_players)
    plan = planner.plan(players, ego=0)
    root, karts = planner.root_state(players, 0)
    tb = planner.tables
    n = track.n_checkpoints
    arrivals: dict[tuple[int, int], list[float]] = {}
    for row, kart in enumerate(karts):
        lane, count, wear = int(root[row, rules.LANE]) + 1, int(root[row, rules.LANE_COUNT]), int(root[row, rules.WEAR])
        checkpoint = int(root[row, rules.CHECKPOINT])
        for wp in plan.waypoints[kart]:
            assert wp.checkpoint == checkpoint + 1
            c = checkpoint % n
            count, illegal = lane_change_update(
                count, lane, wp.lane, bool(tb.straight[c]), bool(tb.straight[(c + 1) % n]), tb.lane_limit
            )
            assert not illegal, f"kart {kart} breaks the lane-change limit at checkpoint {wp.checkpoint}"
            limit = rules.corner_speed(tb, tb.corner_radius[c, lane - 1, wp.lane - 1], wear)
            low = wp.speed - (tb.bin_high[0] - tb.bin_low[0])
            assert low <= limit + 1e-9, f"kart {kart} plans {low} m/s into a {limit:.2f} m/s corner"
            wear = rules.worn_after(tb, wear, tb.turn_angle[c])
            arrivals.setdefault((wp.checkpoint, wp.lane), []).append(wp.time)
            lane, checkpoint = wp.lane, wp.checkpoint
    for times in arrivals.values():
        times.sort()
        for a, b in itertools.pairwise(times):
            assert b - a >= tb.collision_window / 100 - 1e-9, "two karts planned into one lane at one checkpoint"


def test_same_seed_same_plan() -> None:
    track = TRACKS["complex"]
    players = players_from(np.random.default_rng(5), track, 2)
    plans = [TacticalPlanner(track, PAPER_KART, iterations=1500, seed=11).plan(players, 0) for _ in range(2)]
    assert plans[0].waypoints == plans[1].waypoints
    other = TacticalPlanner(track, PAPER_KART, iterations=1500, seed=12).plan(players, 0)
    assert other.iterations == plans[0].iterations


def test_plan_covers_the_horizon_and_maps_lanes_to_track_points() -> None:
    track = TRACKS["oval"]
    players = [PlayerState(0, 30, 2, 12.0, 10.0, 0.25, 0), PlayerState(1, 30, 3, 12.5, 10.1, 0.25, 0)]
    plan = TacticalPlanner(track, PAPER_KART, iterations=3000, seed=0).plan(players, 0)
    ego = plan.ego_waypoints
    assert [w.checkpoint for w in ego][:3] == [31, 32, 33]
    for w in ego:
        assert np.allclose(w.position, track.lane_point(w.checkpoint, w.lane))
        assert 6.0 <= w.speed <= 15.0
    assert set(plan.opponent_waypoints()) == {1}


def test_root_uses_the_real_speed_bin_and_the_section_window() -> None:
    track = TRACKS["oval"]
    planner = TacticalPlanner(track, PAPER_KART)
    far = PlayerState(2, 40, 1, 14.0, 0.0, 0.2, 0)
    players = [PlayerState(0, 31, 2, 12.4, 10.0, 0.25, 1), PlayerState(1, 30, 3, 9.0, 9.6, 0.3, 0), far]
    root, karts = planner.root_state(players, 0)
    assert karts == [0, 1]
    assert root[0, rules.BIN] == 6  # 12.4 m/s lies in [12, 13)
    assert (root[:, rules.CHECKPOINT] == 31).all()  # the kart behind is advanced to the leader's checkpoint
    assert root[0, rules.LANE_COUNT] == 1
    with pytest.raises(ValueError):
        planner.root_state(players, ego=5)


def test_a_kart_behind_is_advanced_by_the_games_own_moves() -> None:
    """The kart behind the leader's checkpoint reaches it by its fastest legal moves in its lane: on the oval's
    start straight it accelerates (9 m/s at checkpoint 1, faster at 2), and it arrives when those moves say."""
    planner = TacticalPlanner(TRACKS["oval"], PAPER_KART)
    players = [PlayerState(0, 2, 2, 12.0, 3.0, 0.25, 0), PlayerState(1, 1, 3, 9.0, 2.5, 0.25, 0)]
    root, _ = planner.root_state(players, 0)
    single = np.zeros((1, rules.N_FIELDS), dtype=np.int64)
    single[0, rules.CHECKPOINT], single[0, rules.LANE], single[0, rules.PREV_LANE] = 1, 2, 2
    single[0, rules.BIN] = planner.speed_bin(9.0)
    single[0, rules.WEAR] = 2500
    grip_now, grip_next = rules.mover_grip(planner.tables, single, 0)
    vbin, arrival, _ = rules.fastest_in_lane(planner.tables, single, 0, 2, grip_now, grip_next)
    assert vbin > planner.speed_bin(9.0)
    assert root[1, rules.CHECKPOINT] == 2 and root[1, rules.LANE] == 2 and root[1, rules.BIN] == vbin
    # times relative to the earlier of the two: 2.5 s + the move's time against 3.0 s
    assert abs((2.5 + arrival / 100.0 - 3.0) * 100.0 - (root[1, rules.TIME] - root[0, rules.TIME])) <= 1.0


@pytest.mark.parametrize("behind", [True, False])
def test_a_kart_at_a_hairpin_entry_enters_the_game_with_a_legal_move(behind: bool) -> None:
    """A kart racing into the hairpin at checkpoint 17 of ``complex`` (6.4 m to brake to 5.6 m/s in the game
    calibrated to the racing line) at 13.5 m/s:
    carried into the game at that speed it had no legal move, and every plan for it was padding (10 of 108
    plans of a race). Whether it is a checkpoint behind the leader (advanced to it) or predicted
    at the hairpin's entry itself, it now enters at a speed the game can brake from, and the search plans it."""
    track = TRACKS["complex"]
    planner = TacticalPlanner(track, PAPER_KART, iterations=500, seed=1, line=optimise_racing_line(track, PAPER_KART))
    ego = PlayerState(0, 16 if behind else 17, 3, 13.5, 10.0, 0.28, 0)
    leader = PlayerState(1, 17, 3, 9.5, 10.0 if behind else 9.3, 0.28, 0, model=rules.MODEL_LINE)
    root, _ = planner.root_state([ego, leader], 0)
    single = root[:1].copy()
    grip_now, grip_next = rules.mover_grip(planner.tables, single, 0)
    assert any(rules.fastest_in_lane(planner.tables, single, 0, j, grip_now, grip_next)[0] >= 0 for j in range(4))
    plan = planner.plan([ego, leader], 0)
    searched = [w for w in plan.ego_waypoints if w.checkpoint > 17]
    assert len(searched) >= planner.params.horizon - 1
    # planned times grow by the game's moves, not by the padding's whole seconds
    assert any(abs(w.time - round(w.time)) > 1e-6 for w in searched)


def test_replanning_from_the_same_root_grows_the_same_tree() -> None:
    track = TRACKS["complex"]
    # (not a random root: one with both karts in one lane within the collision window is a dead end, no tree)
    players = [PlayerState(0, 1, 2, 12.0, 10.0, 0.25, 0), PlayerState(1, 1, 3, 12.5, 10.6, 0.25, 0)]
    planner = TacticalPlanner(track, PAPER_KART, iterations=1000, seed=3)
    first = planner.plan(players, 0)
    second = planner.plan(players, 0)
    assert second.nodes > first.nodes  # the second search continued the first tree
    moved = [PlayerState(p.kart, p.checkpoint + 1, p.lane, p.speed, p.time + 1.0, p.wear, 0) for p in players]
    fresh = planner.plan(moved, 0)
    assert fresh.nodes <= 1001  # a new root starts a new tree
    # and the sequence of plans is reproducible
    again = TacticalPlanner(track, PAPER_KART, iterations=1000, seed=3)
    assert [again.plan(players, 0).waypoints, again.plan(players, 0).waypoints] == [first.waypoints, second.waypoints]


def test_alone_with_a_line_margin_the_plan_is_the_racing_line() -> None:
    """From every checkpoint of the oval at the line's speed, alone: no lane of the search gains 0.1 s on the
    line, so the plan is the line's lanes (without the margin the search's own lanes differ from it at some
    checkpoints: its values differ by hundredths)."""
    track = TRACKS["oval"]
    line = optimise_racing_line(track, PAPER_KART)
    lanes = line.checkpoint_lanes
    n = track.n_checkpoints
    differ = 0
    for cp in range(n, 2 * n):
        me = PlayerState(0, cp, lanes[cp % n], float(line.speed_at(float(track.checkpoint_s[cp % n]))), 0.0, 0.25, 0)
        want = [lanes[c % n] for c in range(cp + 1, cp + 1 + GameParams().horizon)]
        for margin in (0.1, None):
            planner = TacticalPlanner(track, PAPER_KART, iterations=300, seed=cp, line=line, deviation_gain=margin)
            got = [w.lane for w in planner.plan([me], 0).ego_waypoints]
            if margin is not None:
                assert got == want, cp
            else:
                differ += got != want
    assert differ > 0


def _behind_a_slow_kart_on_the_oval() -> tuple[Track, RacingLine, PlayerState, PlayerState]:
    """The oval, its racing line, and the ego 0.3 s behind a line follower doing 8 m/s at checkpoint 10 (the back
    straight), at 14 m/s, both in the line's lane."""
    track = TRACKS["oval"]
    line = optimise_racing_line(track, PAPER_KART)
    lane = line.checkpoint_lanes[10]
    me = PlayerState(0, 10, lane, 14.0, 0.3, 0.25, 0)
    slow = PlayerState(1, 10, lane, 8.0, 0.0, 0.25, 0, model=rules.MODEL_LINE)
    return track, line, me, slow


def test_a_kart_behind_a_slower_one_on_the_line_leaves_the_line_to_pass() -> None:
    """0.3 s behind a line follower doing 8 m/s on the oval's back straight, at 14 m/s: staying on the line
    means braking behind it, so the searched lanes gain more than the margin and replace the line's."""
    track, line, me, slow = _behind_a_slow_kart_on_the_oval()
    lanes = line.checkpoint_lanes
    planner = TacticalPlanner(track, PAPER_KART, iterations=2000, seed=1, line=line, deviation_gain=0.1)
    root, _ = planner.root_state([me, slow], 0)
    following, complete = planner._playout(root, 10, 10, None)
    assert complete
    plan = planner.plan([me, slow], 0)
    assert plan.ego_waypoints[0].lane != lanes[11]
    followed = [s for mover, _, s in following if mover == 0][-1]
    assert plan.ego_waypoints[-1].time * 100.0 <= followed[0, rules.TIME] - 10


def test_a_pass_under_way_is_kept_while_it_still_gains_on_the_line() -> None:
    """The oval's back straight, 0.3 s behind a line follower doing 8 m/s. The previous plan went by on the left
    (lane 1, then 2): it still gains more than ``hold_gain`` on the line, so it is kept even when this plan's own
    choice is the line (the game's play of it, which steps round the slow kart late); without ``hold_gain`` the
    plan is chosen afresh. A previous plan that loses to the line (the far right lane all the way) or never
    left it is not kept."""
    track, line, me, slow = _behind_a_slow_kart_on_the_oval()
    lanes = line.checkpoint_lanes
    planner = TacticalPlanner(track, PAPER_KART, iterations=10, seed=0, line=line, deviation_gain=0.1)
    bins = len(planner.tables.bin_low)
    root, _ = planner.root_state([me, slow], 0)
    on_line, complete = planner._playout(root, 10, 10, None)
    assert complete

    def ego_lanes(moves: list[tuple[int, int, np.ndarray]]) -> list[int]:
        return [action // bins + 1 for mover, action, _ in moves if mover == 0]

    def chosen(hold_gain: float | None, previous: list[int]) -> list[tuple[int, int, np.ndarray]]:
        planner.hold_gain = hold_gain
        committed = {11 + i: lane for i, lane in enumerate(previous)}
        return planner._line_unless_beaten(root, 10, on_line, committed)

    by_the_left = [1, 2, 2, 2, 2, 2, 1, 2]
    kept = chosen(0.05, by_the_left)
    assert ego_lanes(kept) == by_the_left != ego_lanes(on_line)
    assert _advantage(kept) >= _advantage(on_line) + 5  # 0.05 s in the game's 0.01 s units
    assert ego_lanes(chosen(None, by_the_left)) == ego_lanes(on_line)
    assert ego_lanes(chosen(0.05, [4] * 8)) == ego_lanes(on_line)
    line_lanes = [lanes[c % track.n_checkpoints] for c in range(11, 19)]
    assert ego_lanes(chosen(0.05, line_lanes)) == ego_lanes(on_line)
    # a new choice better by more than the margin replaces a previous plan that still gains on the line:
    # lane 1 for two checkpoints gains 0.09 s on the line, 0.1 s less than going by on the left at once
    planner.hold_gain = 0.05
    wider = {11 + i: lane for i, lane in enumerate([1, 1, 2, 2, 2, 2, 1, 2])}
    assert ego_lanes(planner._line_unless_beaten(root, 10, kept, wider)) == by_the_left
    assert _advantage(planner._playout(root, 10, 10, {c: lane - 1 for c, lane in wider.items()})[0]) < (
        _advantage(kept) - HOLD_MARGIN * 100
    )


def test_a_race_with_teams_gives_every_planner_its_karts_team_numbers() -> None:
    """From the race's team names to the game's TEAM column: each kart's PlayerState carries its team number."""
    from controllers.base import RaceContext, team_numbers
    from controllers.race import RaceSpec
    from controllers.tactical.high_level import MCTSPlanner
    from sim_core.observation import observe
    from sim_core.world import World

    spec = RaceSpec("oval", ("mcts-lqng",) * 4, teams=("blue", "red", "blue", "red"))
    assert team_numbers(spec.teams or ()) == (1, 2, 1, 2) and team_numbers(RaceSpec("oval").teams or ()) == ()
    with pytest.raises(ValueError, match="one team for each"):
        RaceSpec("oval", ("mcts-lqng", "e2e"), teams=("blue",))
    track = TRACKS["oval"]
    world = World(track, 1, 4)
    world.reset()
    planner = MCTSPlanner()
    planner.reset(
        RaceContext(track, PAPER_KART, 0, 4, track.lane_change_limit, 0, teams=team_numbers(spec.teams or ()))
    )
    views = observe(world)[0].karts
    players = [planner.present_state(view, 0.0, 0) for view in views]
    assert [p.team for p in players] == [1, 2, 1, 2]
    state, _ = TacticalPlanner(track, PAPER_KART).root_state(players, 0)
    assert sorted(state[:, rules.TEAM].tolist()) == [1, 1, 2, 2]
