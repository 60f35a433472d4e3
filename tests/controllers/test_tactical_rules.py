"""The discrete game's rules, attacked with random play: no sequence of legal moves breaks a rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.tactical import rules
from controllers.tactical.game import GameParams, build_tables
from controllers.tactical.motion import segment_time
from controllers.tactical.value import terminal_values
from sim_core.params import PAPER_KART
from sim_core.rules import lane_change_update
from sim_core.track_io import get_track

TABLES = {
    (name, width): build_tables(get_track(name), PAPER_KART, GameParams(velocity_bin_width=width))
    for name in ("oval", "complex")
    for width in (1.0, 2.0)
}


def random_state(rng: np.random.Generator, tb, n_players: int, checkpoint: int) -> np.ndarray:
    state = np.zeros((n_players, rules.N_FIELDS), dtype=np.int64)
    lanes = rng.choice(4, size=n_players, replace=n_players > 4)
    for p in range(n_players):
        state[p, rules.CHECKPOINT] = checkpoint
        state[p, rules.LANE] = lanes[p]
        state[p, rules.PREV_LANE] = lanes[p]
        state[p, rules.BIN] = rng.integers(0, len(tb.bin_low))
        state[p, rules.TIME] = rng.integers(0, 150)
        state[p, rules.WEAR] = rng.integers(0, 8000)
        state[p, rules.LANE_COUNT] = rng.integers(0, tb.lane_limit + 1)
    return state


@settings(max_examples=60)
@given(
    seed=hs.integers(0, 2**31 - 1),
    key=hs.sampled_from(sorted(TABLES)),
    n_players=hs.integers(1, 4),
    start=hs.integers(0, 40),
)
def test_random_legal_play_never_breaks_a_rule(seed: int, key, n_players: int, start: int) -> None:
    tb = TABLES[key]
    n = len(tb.straight)
    rng = np.random.default_rng(seed)
    state = random_state(rng, tb, n_players, start)
    moves = np.empty(4 * len(tb.bin_low), dtype=np.int64)
    for rnd in range(8):
        round_cp = start + rnd
        while (p := rules.next_player(state, round_cp)) != rules.NO_PLAYER:
            before = state[p].copy()
            count = rules.legal_moves(tb, state, p, moves)
            if count == 0:
                return  # a dead end is a legal outcome of the game
            action = int(moves[rng.integers(0, count)])
            # the mover is the earliest of those still to move: leaders commit first
            assert all(
                state[q, rules.TIME] >= before[rules.TIME]
                for q in range(n_players)
                if state[q, rules.CHECKPOINT] == round_cp
            )
            assert rules.apply_move(tb, state, p, action)
            c = round_cp % n
            lane, vbin = divmod(action, len(tb.bin_low))
            # lane-change rule, judged by the referee's own function
            _, illegal = lane_change_update(
                int(before[rules.LANE_COUNT]),
                int(before[rules.LANE]),
                lane,
                bool(tb.straight[c]),
                bool(tb.straight[(c + 1) % n]),
                tb.lane_limit,
            )
            assert not illegal
            # cornering: above the lowest bin, the bin's lower edge is within the cornering speed of the lane's
            # radius at the wear; the lowest bin stands for any speed up to its top (a worn hairpin is slower
            # than it), and every move is timed arriving at no more than the cornering speed
            v_corner = rules.corner_speed(tb, tb.corner_radius[c, before[rules.LANE], lane], int(before[rules.WEAR]))
            assert vbin == 0 or tb.bin_low[vbin] <= v_corner + 1e-9
            v0 = 0.5 * (tb.bin_low[before[rules.BIN]] + tb.bin_high[before[rules.BIN]])
            v1 = min(0.5 * (tb.bin_low[vbin] + tb.bin_high[vbin]), v_corner)
            seconds = segment_time(tb.distance[c, before[rules.LANE], lane], v0, v1, tb.accel, tb.brake, v_corner)
            assert seconds > 0.0
            penalty = tb.penalty[c, before[rules.LANE], lane]
            assert state[p, rules.TIME] == before[rules.TIME] + int(seconds * 100.0 + penalty + 0.5)
            # collision pruning: nobody already at this checkpoint within the window in this lane, or with the
            # two paths crossing (the sides swapped since the previous checkpoint)
            for q in range(n_players):
                if q == p or state[q, rules.CHECKPOINT] != round_cp + 1:
                    continue
                if abs(state[q, rules.TIME] - state[p, rules.TIME]) < tb.collision_window:
                    assert state[q, rules.LANE] != lane
                    side_before = np.sign(int(before[rules.LANE]) - int(state[q, rules.PREV_LANE]))
                    side_after = np.sign(lane - int(state[q, rules.LANE]))
                    assert side_before * side_after >= 0
            # no dead end: the next section can still be braked for from the arrival speed
            nxt = (c + 1) % n
            v1 = 0.5 * (tb.bin_low[vbin] + tb.bin_high[vbin])  # the next move starts from the bin's middle
            entries = [
                np.sqrt(
                    rules.corner_speed(tb, tb.corner_radius[nxt, lane, j], int(before[rules.WEAR])) ** 2
                    + 2 * tb.brake * tb.distance[nxt, lane, j]
                )
                for j in range(4)
            ]
            assert v1 <= max(entries) + 1e-9
            assert state[p, rules.TIME] > before[rules.TIME]
            assert state[p, rules.WEAR] >= before[rules.WEAR]


def test_cornering_rules_out_fast_bins_in_the_hairpin() -> None:
    tb = TABLES[("complex", 1.0)]
    # complex section 11 is a 90 deg left hairpin with inside radius 1 m: lane 1 (inside) is at r = 1 m
    state = np.zeros((1, rules.N_FIELDS), dtype=np.int64)
    state[0, rules.CHECKPOINT] = 11
    state[0, rules.LANE] = 0
    state[0, rules.BIN] = 0
    state[0, rules.WEAR] = 2500
    moves = np.empty(64, dtype=np.int64)
    count = rules.legal_moves(tb, state, 0, moves)
    bins = len(tb.bin_low)
    inside = [int(m) % bins for m in moves[:count] if int(m) // bins == 0]
    # radius 1 m allows ~3.5 m/s, below the lowest bin (6 m/s): only the lowest (crawling) bin is legal there,
    # and the move is timed at the cornering speed, not at the bin's
    v_corner = rules.corner_speed(tb, tb.corner_radius[11, 0, 0], 2500)
    assert v_corner < tb.bin_low[0]
    assert set(inside) <= {0}
    for vbin in inside:
        arrival, _, ok = rules.move_outcome(tb, state, 0, 0, vbin)
        assert ok and arrival >= 100.0 * tb.distance[11, 0, 0] / tb.bin_low[0]
    for m in moves[:count]:
        lane, vbin = divmod(int(m), bins)
        assert vbin == 0 or tb.bin_low[vbin] <= rules.corner_speed(tb, tb.corner_radius[11, 0, lane], 2500)


def test_wear_grows_through_curves_only() -> None:
    tb = TABLES[("oval", 1.0)]
    assert rules.worn_after(tb, 2500, 0.0) == 2500
    assert rules.worn_after(tb, 2500, np.pi / 4) > 2500
    expected = PAPER_KART.wear_from_yaw(PAPER_KART.yaw_for_wear(0.25) + np.pi / 4)
    assert rules.worn_after(tb, 2500, np.pi / 4) == pytest.approx(expected * 10_000, abs=1)


def test_terminal_values_reward_the_earlier_arrival() -> None:
    tb = TABLES[("oval", 1.0)]
    state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
    state[:, rules.TIME] = (500, 550)
    out = np.empty(2)
    terminal_values(tb, state, np.array([500.0, 550.0]), out)
    # 0.5 s ahead with value_scale 1 s: 0.5 + 0.5 * 0.8 * 0.5; own pace equals the reference
    assert out[0] == pytest.approx(0.7) and out[1] == pytest.approx(0.3)
    terminal_values(tb, state[:1], np.array([600.0]), out[:1])
    assert out[0] == pytest.approx(0.5 + 0.5 * 1.0)  # alone, a full second faster than the reference


def test_a_team_player_values_its_teams_arrival_against_the_opponents() -> None:
    """Players 0 and 1 a team, 2 and 3 the other (value_scale 1 s = 100 units). Player 0 arrives last of its team
    but its team-mate first: the team's mean (5.5 s) is 0.1 s ahead of the opponents' (5.6 s), worth
    0.5 + 0.5 * 0.8 * 0.1 = 0.54 to both team-mates and 0.46 to the opponents; the same arrivals without teams
    give player 0 a 0.1333 s deficit on the others' mean."""
    tb = TABLES[("oval", 1.0)]
    state = np.zeros((4, rules.N_FIELDS), dtype=np.int64)
    state[:, rules.TIME] = (600, 500, 550, 570)
    state[:, rules.TEAM] = (1, 1, 2, 2)
    reference = state[:, rules.TIME].astype(float)
    out = np.empty(4)
    terminal_values(tb, state, reference, out)
    assert out == pytest.approx([0.54, 0.54, 0.46, 0.46])
    state[:, rules.TEAM] = 0
    terminal_values(tb, state, reference, out)
    assert out[0] == pytest.approx(0.5 + 0.4 * ((500 + 550 + 570) / 3 - 600) / 100)
    state[:, rules.TEAM] = (1, 1, 0, 0)  # team-mates against two karts for themselves
    terminal_values(tb, state, reference, out)
    assert out[0] == pytest.approx(0.54) and out[2] == pytest.approx(0.5 + 0.4 * ((500 + 600 + 570) / 3 - 550) / 100)


def test_team_mates_alone_in_the_game_have_no_place_to_gain() -> None:
    """Only team-mates in the game: the race term is 0 (not NaN, as the original's), own pace still counts."""
    tb = TABLES[("oval", 1.0)]
    state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
    state[:, rules.TIME] = (500, 560)
    state[:, rules.TEAM] = 3
    out = np.empty(2)
    terminal_values(tb, state, np.array([520.0, 560.0]), out)
    assert out == pytest.approx([0.5 + 0.5 * 0.2 * 0.2, 0.5])


def test_a_lone_kart_never_runs_into_a_dead_end() -> None:
    """From any lane at any checkpoint, always taking the fastest legal move completes a lap (default 1 m/s
    bins; with 2 m/s bins a few two-section dead ends remain, which the search then avoids by losing)."""
    from controllers.tactical.mcts import greedy_line

    for name in ("oval", "complex"):
        tb = TABLES[(name, 1.0)]
        n = len(tb.straight)
        for start in range(n):
            for lane in range(4):
                state = np.zeros((1, rules.N_FIELDS), dtype=np.int64)
                state[0, rules.CHECKPOINT] = start
                state[0, rules.LANE] = state[0, rules.PREV_LANE] = lane
                state[0, rules.BIN] = 0
                out = np.zeros((n, 2), dtype=np.int64)
                assert greedy_line(tb, state, start, start + n, out) == n


@pytest.mark.parametrize("name", ["oval", "complex"])
def test_worn_tyres_never_lead_a_lone_kart_into_a_dead_end(name: str) -> None:
    """With the line-calibrated tables of a race and the tyres of its last lap (wear 0.5), the hairpins' corner
    speeds fall below the lowest speed bin: they are still taken (in that bin, at their own speed), so the
    fastest legal line from any lane at any checkpoint completes a lap. Before, every line through a worn
    hairpin was a dead end, and a game whose every line is a dead end ranks nothing."""
    from controllers.racing_line import optimise_racing_line
    from controllers.tactical.calibration import calibrate_tables
    from controllers.tactical.mcts import greedy_line

    track = get_track(name)
    tb = calibrate_tables(
        build_tables(track, PAPER_KART, GameParams()), track, optimise_racing_line(track, PAPER_KART), PAPER_KART
    )
    n = len(tb.straight)
    slowest = min(rules.corner_speed(tb, float(tb.corner_radius[c].min()), 5000) for c in range(n))
    for start in range(n):
        for lane in range(4):
            state = np.zeros((1, rules.N_FIELDS), dtype=np.int64)
            state[0, rules.CHECKPOINT] = start
            state[0, rules.LANE] = state[0, rules.PREV_LANE] = lane
            state[0, rules.WEAR] = 5000
            out = np.zeros((n, 2), dtype=np.int64)
            assert greedy_line(tb, state, start, start + n, out) == n, (start, lane)
    if name == "complex":
        assert slowest < tb.bin_low[0]  # the case this test is about does occur


def test_players_side_by_side_may_not_swap_sides() -> None:
    tb = TABLES[("oval", 1.0)]
    # player 1 (lane 2, 0-based 1) reached checkpoint 1 from lane 2 at t = 1.00 s; player 0 comes from lane 3
    state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
    state[:, rules.CHECKPOINT] = (0, 1)
    state[:, rules.LANE] = (2, 1)
    state[:, rules.PREV_LANE] = (2, 1)
    state[:, rules.BIN] = (5, 5)
    state[:, rules.TIME] = (0, 100)
    moves = np.empty(64, dtype=np.int64)
    count = rules.legal_moves(tb, state, 0, moves)
    arrivals = {}
    for m in moves[:count]:
        lane, _ = divmod(int(m), len(tb.bin_low))
        arrival, _, _ = rules.move_outcome(tb, state, 0, lane, int(m) % len(tb.bin_low))
        arrivals.setdefault(lane, []).append(arrival)
    # arriving within the window in lane 1 (across player 1) or lane 2 (its lane) is ruled out
    for lane in (0, 1):
        assert all(abs(a - 100) >= tb.collision_window for a in arrivals.get(lane, []))
    assert arrivals.get(2) or arrivals.get(3)


def test_a_follower_already_within_the_window_keeps_its_distance_but_may_not_close_in() -> None:
    """A follower 0.15 s (2.2 m at 14.5 m/s) behind the leader in its lane, already inside the 3 m window: the
    start is given, so it may follow at that distance or drop back (before, it had no legal move at all and
    its plans were padding), but no move brings it closer to the leader than it already is."""
    tb = build_tables(get_track("oval"), PAPER_KART, GameParams())
    state = np.zeros((2, rules.N_FIELDS), dtype=np.int64)
    state[:, rules.CHECKPOINT] = 1  # the start straight
    state[:, rules.LANE] = state[:, rules.PREV_LANE] = 1
    state[:, rules.BIN] = len(tb.bin_low) - 1
    state[:, rules.TIME] = (15, 0)
    state[:, rules.PREV_TIME] = state[:, rules.TIME]
    state[:, rules.WEAR] = 2500
    moves = np.empty(64, dtype=np.int64)
    assert rules.next_player(state, 1) == 1
    assert rules.legal_moves(tb, state, 1, moves) > 0
    bins = len(tb.bin_low)
    assert rules.apply_move(tb, state, 1, 1 * bins + bins - 1)  # the leader holds its lane at top speed
    count = rules.legal_moves(tb, state, 0, moves)
    assert count > 0
    for m in moves[:count]:
        lane, vbin = divmod(int(m), bins)
        arrival, _, _ = rules.move_outcome(tb, state, 0, lane, vbin)
        if abs(tb.lane_offset[2, lane] - tb.lane_offset[2, 1]) < tb.lateral_clearance:
            assert arrival - state[1, rules.TIME] >= 15
