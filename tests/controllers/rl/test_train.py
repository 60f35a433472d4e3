"""A short seeded self-play training: files written, resumable, and better than a random policy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize

from controllers.rl.batch import RaceBatch
from controllers.rl.config import PPOConfig
from controllers.rl.envs import make_config
from controllers.rl.selfplay import OpponentPool, SelfPlayVecEnv
from controllers.rl.train import CURVES, LOG, MODEL, NORMALISER, mean_decision_reward, policy_actions, train


def test_smoke_training_beats_a_random_policy(tmp_path: Path) -> None:
    env = make_config("mcts-rl", tracks=("train-oval-small",))
    ppo = PPOConfig(total_steps=8192, n_races=32, buffer_size=2048, batch_size=256, save_steps=2048, swap_steps=1024)
    result = train(env, ppo, tmp_path)
    for name in (MODEL, NORMALISER, LOG, CURVES):
        assert (tmp_path / name).exists(), name
    pool = OpponentPool(1, 1.0, 0)
    norm = VecNormalize.load(str(tmp_path / NORMALISER), SelfPlayVecEnv(RaceBatch(env, 32), pool))
    norm.training = False
    model = PPO.load(tmp_path / MODEL, device="cpu")
    rng = np.random.default_rng(0)
    trained = mean_decision_reward(env, policy_actions(model, norm), 32, 150, seed=123)
    random = mean_decision_reward(env, lambda obs: rng.uniform(-1, 1, (obs.shape[0], 2)), 32, 150, seed=123)
    assert trained > random, (trained, random)
    # resuming continues the step count
    more = train(env, PPOConfig(**{**ppo.__dict__, "total_steps": 10240}), tmp_path, resume=True)
    assert more.timesteps >= 10240 > result.timesteps - 1
    # fine-tuning starts from those weights and statistics with a fresh step count, into another folder
    # (two rollouts: the linear schedule reaches 0 at the end, so a one-rollout run would update at rate 0)
    tuned = train(env, PPOConfig(**{**ppo.__dict__, "total_steps": 4096}), tmp_path / "tuned", fine_tune_from=tmp_path)
    assert 4096 <= tuned.timesteps < 6144
    start = PPO.load(tmp_path / MODEL, device="cpu").policy.state_dict()
    after = PPO.load(tmp_path / "tuned" / MODEL, device="cpu").policy.state_dict()
    assert any(not np.allclose(start[k].numpy(), after[k].numpy()) for k in start)
    base = VecNormalize.load(str(tmp_path / NORMALISER), SelfPlayVecEnv(RaceBatch(env, 32), pool)).obs_rms.count
    assert (
        VecNormalize.load(str(tmp_path / "tuned" / NORMALISER), SelfPlayVecEnv(RaceBatch(env, 32), pool)).obs_rms.count
        > base
    )
