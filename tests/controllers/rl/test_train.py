"""A short seeded self-play training: files written, resumable, and better than a random policy."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize

from controllers.rl.batch import RaceBatch
from controllers.rl.config import PPOConfig
from controllers.rl.envs import make_config
from controllers.rl.selfplay import OpponentPool, SelfPlayVecEnv
from controllers.rl.train import CURVES, LOG, MODEL, NORMALISER, SETTINGS, mean_decision_reward, policy_actions, train


def test_smoke_training_beats_a_random_policy(tmp_path: Path) -> None:
    env = make_config("mcts-rl", tracks=("train-oval-small",))
    ppo = PPOConfig(total_steps=8192, n_races=32, buffer_size=2048, batch_size=256, save_steps=2048, swap_steps=1024)
    result = train(env, ppo, tmp_path)
    for name in (MODEL, NORMALISER, LOG, CURVES, SETTINGS):
        assert (tmp_path / name).exists(), name
    (run,) = json.loads((tmp_path / SETTINGS).read_text())
    assert run["env"]["weights"]["target_lane"] == env.weights.target_lane and run["ppo"]["total_steps"] == 8192
    assert run["env"]["tracks"] == ["train-oval-small"] and not run["resumed"] and run["fine_tune_from"] is None
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
    runs = json.loads((tmp_path / SETTINGS).read_text())
    assert [r["resumed"] for r in runs] == [False, True] and runs[1]["start_steps"] == result.timesteps
    # fine-tuning starts from those weights and statistics with a fresh step count, into another folder
    # (two rollouts: the linear schedule reaches 0 at the end, so a one-rollout run would update at rate 0)
    tuned = train(env, PPOConfig(**{**ppo.__dict__, "total_steps": 4096}), tmp_path / "tuned", fine_tune_from=tmp_path)
    assert 4096 <= tuned.timesteps < 6144
    (tuned_run,) = json.loads((tmp_path / "tuned" / SETTINGS).read_text())
    assert tuned_run["fine_tune_from"] == str(tmp_path) and tuned_run["start_steps"] == 0
    start = PPO.load(tmp_path / MODEL, device="cpu").policy.state_dict()
    after = PPO.load(tmp_path / "tuned" / MODEL, device="cpu").policy.state_dict()
    assert any(not np.allclose(start[k].numpy(), after[k].numpy()) for k in start)
    base = VecNormalize.load(str(tmp_path / NORMALISER), SelfPlayVecEnv(RaceBatch(env, 32), pool)).obs_rms.count
    assert (
        VecNormalize.load(str(tmp_path / "tuned" / NORMALISER), SelfPlayVecEnv(RaceBatch(env, 32), pool)).obs_rms.count
        > base
    )


def test_a_shipped_agent_fine_tunes_from_its_inference_files(tmp_path: Path) -> None:
    """The shipped folders hold the actor only (policy.npz): fine-tuning starts from exactly that policy."""
    import torch

    from controllers.rl.policy import load_policy
    from controllers.rl.train import load_actor, make_model

    shipped = Path("controllers/rl/weights/e2e")
    env = make_config("e2e", tracks=("train-oval-small",))
    ppo = PPOConfig(total_steps=4096, n_races=32, buffer_size=2048, batch_size=256, save_steps=2048, swap_steps=1024)
    venv = VecNormalize(SelfPlayVecEnv(RaceBatch(env, 32), OpponentPool(1, 1.0, 0)), norm_obs=True, clip_obs=10.0)
    model = make_model(venv, ppo)
    load_actor(model, venv, shipped)
    policy = load_policy(shipped)
    obs = venv.reset()
    raw = venv.get_original_obs()[:4]
    with torch.no_grad():
        mean = model.policy.get_distribution(torch.as_tensor(venv.normalize_obs(raw))).distribution.mean.numpy()
    expected = np.stack([policy.mean(o) for o in raw])
    # float32 torch against the float64 inference path: equal to about 1e-4
    assert obs.shape[0] == 32 and np.allclose(mean, expected, atol=1e-3), (mean, expected)
    tuned = train(env, ppo, tmp_path / "tuned", fine_tune_from=shipped)
    assert tuned.timesteps >= 4096 and (tmp_path / "tuned" / MODEL).exists()


def test_a_shipped_agent_fine_tuned_in_a_field_starts_as_the_shipped_policy_on_what_it_saw() -> None:
    """Training races of 4 karts: the shipped 2-kart actor widened, acting on each kart's observation as the shipped
    policy acts on the same observation without the two added opponents."""
    from dataclasses import replace

    import torch

    from controllers.rl.config import STACK
    from controllers.rl.observations import widened_columns
    from controllers.rl.policy import load_policy
    from controllers.rl.train import load_actor, make_model

    shipped = Path("controllers/rl/weights/e2e")
    env = replace(make_config("e2e", tracks=("train-oval-small",)), n_karts=4)
    ppo = PPOConfig(total_steps=2048, n_races=8, buffer_size=1024, batch_size=256)
    venv = VecNormalize(SelfPlayVecEnv(RaceBatch(env, 8), OpponentPool(1, 1.0, 0)), norm_obs=True, clip_obs=10.0)
    model = make_model(venv, ppo)
    load_actor(model, venv, shipped)
    venv.reset()
    raw = venv.get_original_obs()[:4]
    source, added = widened_columns(2, 4, STACK)
    narrow = np.zeros((len(raw), STACK * 55))
    narrow[:, source[~added]] = raw[:, ~added]  # the shipped agent's view: the first opponent only
    with torch.no_grad():
        mean = model.policy.get_distribution(torch.as_tensor(venv.normalize_obs(raw))).distribution.mean.numpy()
    policy = load_policy(shipped)
    assert raw.shape[1] == STACK * 79 and np.allclose(mean, np.stack([policy.mean(o) for o in narrow]), atol=1e-3)


def test_the_pool_drives_opponents_by_a_copy_of_the_actor_frozen_when_added() -> None:
    """A snapshot's mean action (its numpy policy, and the float32 layers the pool drives by) equals the torch
    actor's at the time it was added, row by row and batched, and later training of the live policy does not
    move it; its samples are seeded by the pool."""
    import torch

    from controllers.rl.train import make_model

    env = make_config("mcts-rl", tracks=("train-oval-small",))
    ppo = PPOConfig(total_steps=2048, n_races=8, buffer_size=1024, batch_size=256)
    venv = VecNormalize(SelfPlayVecEnv(RaceBatch(env, 8), OpponentPool(1, 1.0, 0)), norm_obs=True, clip_obs=10.0)
    model = make_model(venv, ppo)
    raw = np.random.default_rng(1).normal(size=(5, venv.observation_space.shape[0])) * 3.0
    mean, var = raw.mean(axis=0), raw.var(axis=0) + 0.5
    pool = OpponentPool(2, 1.0, seed=7)
    pool.add(model.policy, mean, var, 0)
    with torch.no_grad():
        x = torch.as_tensor(np.clip((raw - mean) / np.sqrt(var + 1e-8), -10, 10), dtype=torch.float32)
        expected = model.policy.get_distribution(x).distribution.mean.numpy()
    frozen = pool.snapshots[0].policy
    assert np.allclose(frozen.mean(raw), expected, atol=1e-4)
    assert np.allclose(np.stack([frozen.mean(r) for r in raw]), frozen.mean(raw), atol=1e-12)
    # the float32 layers compute what the live policy's float32 forward does
    assert np.allclose(pool.snapshots[0].mean(raw), expected, atol=1e-6)
    with torch.no_grad():
        for p in model.policy.parameters():
            p.add_(1.0)
    assert np.allclose(frozen.mean(raw), expected, atol=1e-4)
    assert np.allclose(pool.snapshots[0].mean(raw), expected, atol=1e-6)
    again = OpponentPool(2, 1.0, seed=7)
    again.add(model.policy, mean, var, 0)
    again.snapshots[0] = pool.snapshots[0]
    again.current = again.snapshots[0]
    first, second = pool(raw), again(raw)
    assert first.shape == (5, 2) and np.all(np.abs(first) <= 1.0) and np.array_equal(first, second)
