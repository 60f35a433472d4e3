"""The environments against the ecosystem's own checkers, and seeded determinism."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test

from controllers.rl.batch import RaceBatch
from controllers.rl.envs import KartRaceEnv, KartRaceVectorEnv, make_config, parallel_env
from controllers.rl.observations import PHANTOM_GAP
from sim_core import state as st


def test_gymnasium_check_env() -> None:
    check_env(KartRaceEnv(agent="mcts-rl"), skip_render_check=True)


def test_pettingzoo_parallel_api() -> None:
    parallel_api_test(parallel_env(agent="fixed-rl"), num_cycles=200)


def test_registered_ids_make_single_and_vector_envs() -> None:
    env = gym.make("controllers.rl.envs:karting/KartRace-E2E-v0")
    obs, _ = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    envs = gym.make_vec("karting/KartRace-v0", num_envs=8, vectorization_mode="vector_entry_point", agent="e2e")
    obs, _ = envs.reset(seed=1)
    assert obs.shape == (8, 220)


def test_vector_env_spaces_autoreset_and_episode_info() -> None:
    envs = KartRaceVectorEnv(num_envs=8, agent="mcts-rl", episode_steps=40)
    obs, _ = envs.reset(seed=3)
    assert envs.observation_space.contains(obs)
    ended_seen = False
    for _ in range(25):  # 40 physics steps = 20 decisions: every race ends once
        obs, reward, term, trunc, infos = envs.step(envs.action_space.sample())
        assert obs.dtype == np.float32 and reward.shape == (8,) and np.isfinite(reward).all()
        if "final_obs" in infos:
            ended_seen = True
            ended = infos["_final_obs"]
            assert (ended == (term | trunc)).all()
            for b in np.flatnonzero(ended):
                assert envs.single_observation_space.contains(infos["final_obs"][b])
                assert infos["episode"]["l"][b] >= 1
    assert ended_seen


def test_seeded_batch_is_deterministic() -> None:
    def run() -> tuple[np.ndarray, np.ndarray]:
        batch = RaceBatch(make_config("mcts-rl"), 8, seed=11)
        batch.reset()
        rng = np.random.default_rng(5)
        total = np.zeros((8, 2))
        for _ in range(60):
            result = batch.step(rng.uniform(-1, 1, (8, 2, 2)))
            total += result.reward
        return result.obs, total

    obs_a, ret_a = run()
    obs_b, ret_b = run()
    assert np.array_equal(obs_a, obs_b) and np.array_equal(ret_a, ret_b)
    assert obs_a.shape == (8, 2, 220)


def test_solo_training_races_show_their_opponents_as_phantoms_behind_the_learner() -> None:
    """With ``solo_probability`` 1 every race's other kart is a finished phantom 30 m behind kart 0, at the spawn
    and after every decision; with the default 0 nobody is absent."""
    batch = RaceBatch(replace(make_config("fixed-rl"), solo_probability=1.0), 6, seed=3)
    batch.reset(3)
    rng = np.random.default_rng(0)
    for _ in range(20):
        for block in batch.blocks:
            f, i = block.world.fstate, block.world.istate
            assert block.absent[:, 1].all() and not block.absent[:, 0].any()
            assert (i[:, 1, st.I_FINISHED] == 1).all() and (i[:, 0, st.I_FINISHED] == 0).all()
            gap = np.hypot(f[:, 0, st.F_X] - f[:, 1, st.F_X], f[:, 0, st.F_Y] - f[:, 1, st.F_Y])
            np.testing.assert_allclose(gap, PHANTOM_GAP)
        batch.step(rng.uniform(-1.0, 1.0, size=(6, 2, 2)))
    plain = RaceBatch(make_config("fixed-rl"), 6, seed=3)
    plain.reset(3)
    assert not any(block.absent.any() for block in plain.blocks)
