"""The discrete game's rules, attacked with random play: no sequence of legal moves breaks a rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.tactical import discrete as dg
from controllers.tactical.game import GameParams, build_tables
from sim_core.params import PAPER_KART
from sim_core.rules import lane_change_update
from sim_core.track_io import get_track

TABLES = {
    (name, width): build_tables(get_track(name), PAPER_KART, GameParams(velocity_bin_width=width))
    for name in ("oval", "complex")
    for width in (1.0, 2.0)
}


def random_state(rng: np.random.Generator, tb, n_players: int, checkpoint: int) -> np.ndarray:
    state = np.zeros((n_players, dg.N_FIELDS), dtype=np.int64)
    lanes = rng.choice(4, size=n_players, replace=n_players > 4)
    for p in range(n_players):
        state[p, dg.CHECKPOINT] = checkpoint
        state[p, dg.LANE] = lanes[p]
        state[p, dg.PREV_LANE] = lanes[p]
        state[p, dg.BIN] = rng.integers(0, len(tb.bin_low))
        state[p, dg.TIME] = rng.integers(0, 150)
        state[p, dg.WEAR] = rng.integers(0, 8000)
        state[p, dg.LANE_COUNT] = rng.integers(0, tb.lane_limit + 1)
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
        while (p := dg.next_player(state, round_cp)) != dg.NO_PLAYER:
            before = state[p].copy()
            count = dg.legal_moves(tb, state, p, moves)
            if count == 0:
                return  # a dead end is a legal outcome of the game
            action = int(moves[rng.integers(0, count)])
            # the mover is the earliest of those still to move: leaders commit first
            assert all(
                state[q, dg.TIME] >= before[dg.TIME] for q in range(n_players) if state[q, dg.CHECKPOINT] == round_cp
            )
            assert dg.apply_move(tb, state, p, action)
            c = round_cp % n
            lane, vbin = divmod(action, len(tb.bin_low))
            # lane-change rule, judged by the referee's own function
            _, illegal = lane_change_update(
                int(before[dg.LANE_COUNT]),
                int(before[dg.LANE]),
                lane,
                bool(tb.straight[c]),
                bool(tb.straight[(c + 1) % n]),
                tb.lane_limit,
            )
            assert not illegal
            # cornering: the bin's lower edge is within the cornering speed of the lane's radius at the wear
            assert (
                tb.bin_low[vbin]
                <= dg.corner_speed(tb, tb.corner_radius[c, before[dg.LANE], lane], int(before[dg.WEAR])) + 1e-9
            )
            # collision pruning: nobody already at this checkpoint within the window in this lane, or with the
            # two paths crossing (the sides swapped since the previous checkpoint)
            for q in range(n_players):
                if q == p or state[q, dg.CHECKPOINT] != round_cp + 1:
                    continue
                if abs(state[q, dg.TIME] - state[p, dg.TIME]) < tb.collision_window:
                    assert state[q, dg.LANE] != lane
                    side_before = np.sign(int(before[dg.LANE]) - int(state[q, dg.PREV_LANE]))
                    side_after = np.sign(lane - int(state[q, dg.LANE]))
                    assert side_before * side_after >= 0
            # no dead end: the next section can still be braked for from the arrival speed
            nxt = (c + 1) % n
            v1 = 0.5 * (tb.bin_low[vbin] + tb.bin_high[vbin])  # the next move starts from the bin's middle
            entries = [
                np.sqrt(
                    dg.corner_speed(tb, tb.corner_radius[nxt, lane, j], int(before[dg.WEAR])) ** 2
                    + 2 * tb.brake * tb.distance[nxt, lane, j]
                )
                for j in range(4)
            ]
            assert v1 <= max(entries) + 1e-9
            assert state[p, dg.TIME] > before[dg.TIME]
            assert state[p, dg.WEAR] >= before[dg.WEAR]


def test_cornering_rules_out_fast_bins_in_the_hairpin() -> None:
    tb = TABLES[("complex", 1.0)]
    # complex section 11 is a 90 deg left hairpin with inside radius 1 m: lane 1 (inside) is at r = 1 m
    state = np.zeros((1, dg.N_FIELDS), dtype=np.int64)
    state[0, dg.CHECKPOINT] = 11
    state[0, dg.LANE] = 0
    state[0, dg.BIN] = 0
    state[0, dg.WEAR] = 2500
    moves = np.empty(64, dtype=np.int64)
    count = dg.legal_moves(tb, state, 0, moves)
    lanes = {int(m) // len(tb.bin_low) for m in moves[:count]}
    assert 0 not in lanes  # radius 1 m allows ~3.5 m/s, below the lowest bin (6 m/s)
    for m in moves[:count]:
        lane, vbin = divmod(int(m), len(tb.bin_low))
        assert tb.bin_low[vbin] <= dg.corner_speed(tb, tb.corner_radius[11, 0, lane], 2500)


def test_wear_grows_through_curves_only() -> None:
    tb = TABLES[("oval", 1.0)]
    assert dg.worn_after(tb, 2500, 0.0) == 2500
    assert dg.worn_after(tb, 2500, np.pi / 4) > 2500
    expected = PAPER_KART.wear_from_yaw(PAPER_KART.yaw_for_wear(0.25) + np.pi / 4)
    assert dg.worn_after(tb, 2500, np.pi / 4) == pytest.approx(expected * 10_000, abs=1)


def test_terminal_values_reward_the_earlier_arrival() -> None:
    tb = TABLES[("oval", 1.0)]
    state = np.zeros((2, dg.N_FIELDS), dtype=np.int64)
    state[:, dg.TIME] = (500, 550)
    out = np.empty(2)
    dg.terminal_values(tb, state, np.array([500.0, 550.0]), out)
    # 0.5 s ahead with value_scale 1 s: 0.5 + 0.5 * 0.8 * 0.5; own pace equals the reference
    assert out[0] == pytest.approx(0.7) and out[1] == pytest.approx(0.3)
    dg.terminal_values(tb, state[:1], np.array([600.0]), out[:1])
    assert out[0] == pytest.approx(0.5 + 0.5 * 1.0)  # alone, a full second faster than the reference


def test_a_lone_kart_never_runs_into_a_dead_end() -> None:
    """From any lane at any checkpoint, always taking the fastest legal move completes a lap (default 1 m/s
    bins; with 2 m/s bins a few two-section dead ends remain, which the search then avoids by losing)."""
    from controllers.tactical.mcts import greedy_line

    for name in ("oval", "complex"):
        tb = TABLES[(name, 1.0)]
        n = len(tb.straight)
        for start in range(n):
            for lane in range(4):
                state = np.zeros((1, dg.N_FIELDS), dtype=np.int64)
                state[0, dg.CHECKPOINT] = start
                state[0, dg.LANE] = state[0, dg.PREV_LANE] = lane
                state[0, dg.BIN] = 0
                out = np.zeros((n, 2), dtype=np.int64)
                assert greedy_line(tb, state, start, start + n, out) == n


def test_players_side_by_side_may_not_swap_sides() -> None:
    tb = TABLES[("oval", 1.0)]
    # player 1 (lane 2, 0-based 1) reached checkpoint 1 from lane 2 at t = 1.00 s; player 0 comes from lane 3
    state = np.zeros((2, dg.N_FIELDS), dtype=np.int64)
    state[:, dg.CHECKPOINT] = (0, 1)
    state[:, dg.LANE] = (2, 1)
    state[:, dg.PREV_LANE] = (2, 1)
    state[:, dg.BIN] = (5, 5)
    state[:, dg.TIME] = (0, 100)
    moves = np.empty(64, dtype=np.int64)
    count = dg.legal_moves(tb, state, 0, moves)
    arrivals = {}
    for m in moves[:count]:
        lane, _ = divmod(int(m), len(tb.bin_low))
        arrival, _, _ = dg.move_outcome(tb, state, 0, lane, int(m) % len(tb.bin_low))
        arrivals.setdefault(lane, []).append(arrival)
    # arriving within the window in lane 1 (across player 1) or lane 2 (its lane) is ruled out
    for lane in (0, 1):
        assert all(abs(a - 100) >= tb.collision_window for a in arrivals.get(lane, []))
    assert arrivals.get(2) or arrivals.get(3)
