"""The compiled per-decision sums of the training batch against the appendix's term functions, bit for bit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.rl import rewards as rw
from controllers.rl.batch import Block, RaceBatch
from controllers.rl.config import DECISION_STEPS
from controllers.rl.envs import make_config
from controllers.rl.observations import target_indices, target_points
from sim_core import state as st
from sim_core.params import DT


def reference_decision_terms(batch: RaceBatch, block: Block, active: np.ndarray, last_illegal: np.ndarray) -> dict:
    """Each term by its function in :mod:`controllers.rl.rewards`, over whole arrays."""
    wt, w = batch.config.weights, block.world
    f, i = w.fstate, w.istate
    speed = f[:, :, st.F_SPEED]
    target = target_points(block.tables, block.plan_lane, target_indices(w, block.tables)[:, :, :1])[:, :, 0]
    course = f[:, :, st.F_HEADING] + f[:, :, st.F_SLIP]
    hits = rw.player_rays(w.ray_dist, w.ray_hit).sum(axis=-1)
    if batch.n_karts == 2:
        on_me = hits[:, ::-1].astype(float)
    else:
        pos = w.positions
        gap = np.hypot(*(pos[:, :, None, :] - pos[:, None, :, :]).transpose(3, 0, 1, 2))
        gap[:, np.arange(batch.n_karts), np.arange(batch.n_karts)] = np.inf
        nearest = gap.argmin(axis=2)
        on_me = np.zeros(hits.shape)
        rows = np.repeat(np.arange(hits.shape[0]), batch.n_karts)
        np.add.at(on_me, (rows, nearest.ravel()), hits.ravel())
    return {
        "speed": DECISION_STEPS * rw.speed_reward(wt.speed, speed, batch.kart.top_speed),
        "direction": DECISION_STEPS * rw.direction_reward(wt.direction, w.positions, course, speed, target),
        "acceleration": DECISION_STEPS * rw.acceleration_reward(wt.acceleration, block.accelerating),
        "not_at_goal": DECISION_STEPS * rw.not_at_goal_penalty(wt.not_at_goal, active),
        "swerve": rw.swerve_penalty(wt.swerve, i[:, :, st.I_ILLEGAL_STEP] - last_illegal),
        "wall_hit": rw.wall_hit_penalty(wt.wall_hit, w.ray_dist, w.ray_hit),
        "player_hit": rw.player_hit_penalty(wt.player_hit, wt.player_hit_front, w.ray_dist, w.ray_hit),
        "hit_by_player": rw.hit_by_player_penalty(wt.hit_by_player, on_me),
    }


def reference_checkpoint_terms(
    batch: RaceBatch, block: Block, active: np.ndarray, passed_before: np.ndarray, since_before: np.ndarray
) -> np.ndarray:
    """The checkpoint terms by their functions, kart by kart; updates ``block.reach_count`` and ``first_time``."""
    wt, w, t = batch.config.weights, block.world, block.tables
    f, i = w.fstate, w.istate
    passed = i[:, :, st.I_CP_PASSED]
    since = np.mod(f[:, :, st.F_S] - t.checkpoint_s[np.mod(passed, t.n_checkpoints)], t.length)
    out = np.zeros(passed.shape)
    reversed_ = active & (passed == passed_before) & (since_before < t.length / 2) & (since > t.length / 2)
    out += np.where(reversed_, rw.reverse_penalty(wt.reverse, np.zeros(passed.shape)), 0.0)
    rows = np.arange(passed.shape[0])
    for k in range(batch.n_karts):
        crossed = active[:, k] & (passed[:, k] > passed_before[:, k])
        r = rows[crossed]
        m = np.clip(passed[r, k] + 1, 0, block.reach_count.shape[1] - 1)
        order = block.reach_count[r, m]
        time = f[r, k, st.F_CROSS_TIME]
        first = np.where(order == 0, time, block.first_time[r, m])
        block.first_time[r, m] = first
        block.reach_count[r, m] += 1
        c = np.mod(passed[r, k], t.n_checkpoints)
        lane_miss = np.abs(f[r, k, st.F_D] - t.offsets[c, block.plan_lane[r, k, c]])
        speed_miss = f[r, k, st.F_CROSS_SPEED] - block.plan_speed[r, k, c]
        out[r, k] += (
            rw.checkpoint_base_reward(wt.checkpoint_base, order)
            + rw.checkpoint_time_reward(wt.checkpoint_time, order, time, batch.horizon)
            + rw.behind_opponent_penalty(wt.behind_opponent, (time - first) / DT)
            + rw.target_lane_reward(wt.target_lane, lane_miss)
            + rw.target_speed_reward(wt.target_speed, speed_miss, batch.config.agent == "mcts-rl")
        )
    return out


@pytest.mark.parametrize(("agent", "n_karts", "seed"), [("mcts-rl", 2, 3), ("fixed-rl", 3, 4), ("e2e", 2, 5)])
def test_compiled_reward_sums_equal_the_term_functions_bit_for_bit(agent: str, n_karts: int, seed: int) -> None:
    """Random driving with a forward bias (checkpoints, walls, kart contacts, reversing): every term of every
    kart, the decision's reward and the checkpoint bookkeeping, on every track."""
    config = replace(make_config(agent), n_karts=n_karts)
    batch = RaceBatch(config, 24, seed=seed, autoreset=False)
    batch.reset()
    rng = np.random.default_rng(seed)
    crossings = reversals = contacts = 0
    for _ in range(250):
        before = [
            (b.world.istate[:, :, st.I_FINISHED] == 0, b.passed.copy(), b.since.copy(), b.illegal.copy())
            for b in batch.blocks
        ]
        counts = [(b.reach_count.copy(), b.first_time.copy()) for b in batch.blocks]
        actions = rng.uniform(-1.0, 1.0, (24, n_karts, 2))
        actions[..., 1] += rng.choice([0.8, -0.6], size=(24, n_karts), p=[0.9, 0.1])
        result = batch.step(np.clip(actions, -1.0, 1.0))
        for block, (active, passed, since, illegal), (reach, first) in zip(batch.blocks, before, counts):
            sl = slice(block.offset, block.offset + block.world.n_races)
            want = reference_decision_terms(batch, block, active, illegal)
            assert list(block.terms) == list(want)
            for name, value in want.items():
                assert np.array_equal(block.terms[name], value), name
            compiled = (block.reach_count.copy(), block.first_time.copy())
            block.reach_count[:], block.first_time[:] = reach, first
            scored = reference_checkpoint_terms(batch, block, active, passed, since)
            assert np.array_equal(block.reach_count, compiled[0]) and np.array_equal(block.first_time, compiled[1])
            total = sum(np.where(active, v, 0.0) for v in want.values()) + scored
            assert np.array_equal(result.reward[sl], total)
            crossings += int((block.passed > passed).sum())
            reversals += int((scored < 0).sum())
            contacts += int((want["player_hit"] < 0).sum())
    assert crossings > 50 and contacts > 0, (crossings, reversals, contacts)
