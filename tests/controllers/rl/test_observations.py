"""The compiled frame builder against the array formulas of the spec's observation, bit for bit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from controllers.rl.batch import RaceBatch
from controllers.rl.config import SPEED_SCALE
from controllers.rl.envs import make_config
from controllers.rl.observations import TrackTables, build_frame, ego_frame, target_indices, target_points
from sim_core import state as st
from sim_core.world import World


def reference_frame(
    world: World,
    tables: TrackTables,
    plan_lane: np.ndarray,
    plan_speed: np.ndarray,
    accelerating: np.ndarray,
    time_fraction: np.ndarray,
) -> np.ndarray:
    """The observation frame as whole-array numpy formulas (own, each opponent, targets, rays)."""
    f, i = world.fstate, world.istate
    n_races, n_karts = f.shape[:2]
    n = tables.n_checkpoints
    speed, passed = f[:, :, st.F_SPEED], i[:, :, st.I_CP_PASSED]
    active = 1.0 - i[:, :, st.I_FINISHED]
    straight = tables.straight[np.mod(passed, n)]
    lap_frac = np.mod(passed, n) / n
    lanes = i[:, :, st.I_LANE_NOW].astype(float)
    changes = i[:, :, st.I_STEP_LANE_COUNT] / max(world.lane_change_limit, 1)
    wear = f[:, :, st.F_WEAR]
    x, y, heading = f[:, :, st.F_X], f[:, :, st.F_Y], f[:, :, st.F_HEADING]
    own = [speed / SPEED_SCALE, accelerating, lanes, changes, active, lap_frac, straight, wear]
    parts = [np.stack([*own, np.broadcast_to(time_fraction[:, None], speed.shape)], axis=-1)]
    for shift in range(1, n_karts):
        j = (np.arange(n_karts) + shift) % n_karts
        dx, dy = x[:, j] - x, y[:, j] - y
        fx, fy = ego_frame(dx, dy, heading)
        rel = np.mod(heading[:, j] - heading + np.pi, 2 * np.pi) - np.pi
        seen = [speed[:, j] / SPEED_SCALE, accelerating[:, j], lanes[:, j], changes[:, j], active[:, j]]
        seen += [straight[:, j], wear[:, j], lap_frac[:, j], np.hypot(dx, dy), fx, fy, rel / np.pi]
        parts.append(np.stack(seen, axis=-1))
    idx = target_indices(world, tables)
    pts = target_points(tables, plan_lane, idx)
    dx, dy = pts[..., 0] - x[:, :, None], pts[..., 1] - y[:, :, None]
    fx, fy = ego_frame(dx, dy, heading[:, :, None])
    tspeed = np.take_along_axis(plan_speed, idx, axis=2) / SPEED_SCALE
    targets = np.stack([fx, fy, np.hypot(dx, dy), tspeed, tables.straight[np.mod(idx - 1, n)]], axis=-1)
    parts.append(targets.reshape(n_races, n_karts, -1))
    parts.append(world.ray_dist / world.params.sensors.max_range)
    return np.concatenate(parts, axis=-1)


@pytest.mark.parametrize(("agent", "n_karts", "solo"), [("mcts-rl", 2, 0.3), ("e2e", 3, 0.0), ("fixed-rl", 4, 0.5)])
def test_compiled_frames_equal_the_array_formulas_bit_for_bit(agent: str, n_karts: int, solo: float) -> None:
    """Over random driving (wall contacts, lane changes, crossings, phantoms), every frame of every track."""
    config = replace(make_config(agent), n_karts=n_karts, solo_probability=solo)
    batch = RaceBatch(config, 12, seed=5)
    batch.reset()
    rng = np.random.default_rng(1)
    compared = 0
    for _ in range(120):
        batch.step(rng.uniform(-1.0, 1.0, (12, n_karts, 2)))
        for block in batch.blocks:
            w = block.world
            args = (w, block.tables, block.plan_lane, block.plan_speed, block.accelerating, w.time / batch.horizon)
            got, want = build_frame(*args), reference_frame(*args)
            assert got.shape == want.shape and np.array_equal(got, want), np.argwhere(got != want)[:5]
            compared += 1
    assert compared == 120 * len(batch.blocks)
