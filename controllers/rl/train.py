"""``karting train AGENT``: PPO (Stable-Baselines3) with self-play on the training ovals.

The spec's defaults (:class:`controllers.rl.config.PPOConfig`): 3x128 tanh policy and value networks, lr 2e-4
decaying linearly, minibatch 512, a 10240-step buffer, 3 epochs, gamma 0.99, lambda 0.95, clip 0.2, entropy
5e-3, running observation normalisation (VecNormalize); a pool of 10 frozen past policies, a snapshot every
20k steps, the opponent swapped every 10k, half the games against the latest. The output folder holds the
model (``model.zip``), the normalisation statistics (``vecnormalize.pkl``), periodic checkpoints, the log
(``training_log.csv``) and its curves (``curves.png``); training resumes from it.
"""

from __future__ import annotations

import csv
import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.running_mean_std import RunningMeanStd
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import VecNormalize

from controllers.rl.batch import RaceBatch
from controllers.rl.config import STACK, EnvConfig, PPOConfig
from controllers.rl.curves import LOG_FIELDS, plot_curves
from controllers.rl.observations import race_karts, widened_columns
from controllers.rl.policy import POLICY_FILE
from controllers.rl.selfplay import OpponentPool, SelfPlayVecEnv

MODEL, NORMALISER, LOG, CURVES = "model.zip", "vecnormalize.pkl", "training_log.csv", "curves.png"
SETTINGS = "training_settings.json"  # one entry per run into the folder: every setting it trained with
# observations behind a shipped agent's statistics: weight enough that fine-tuning moves them slowly (its count
# is not shipped)
SHIPPED_STATISTICS_COUNT = 1e6


@dataclass
class TrainResult:
    """Where a training run left its files, and how fast it went."""

    out: Path
    timesteps: int
    wall_s: float
    env_steps_per_s: float
    rollout_s: float = 0.0  # of wall_s: collecting rollouts (the races, the policy's actions, the buffer)
    update_s: float = 0.0  # of wall_s: the PPO updates (the epochs over each rollout)
    log: Path = field(init=False)

    def __post_init__(self) -> None:
        self.log = self.out / LOG


class SelfPlayCallback(BaseCallback):
    """Snapshots into the pool, opponent swaps, the log row after every update and periodic checkpoints."""

    def __init__(self, pool: OpponentPool, norm: VecNormalize, ppo: PPOConfig, out: Path) -> None:
        super().__init__()
        self.pool, self.norm, self.ppo, self.out = pool, norm, ppo, out
        self.next_save = self.next_swap = self.next_checkpoint = 0
        self.start = time.perf_counter()
        self.start_steps = 0
        self.rollout_s = self.update_s = 0.0  # wall time in rollouts and in the updates between them
        self._rollout_start = self._rollout_end = 0.0

    def _on_training_start(self) -> None:
        n = self.num_timesteps
        self.start_steps = n
        self.next_save, self.next_swap = n + self.ppo.save_steps, n + self.ppo.swap_steps
        self.next_checkpoint = n + self.ppo.checkpoint_steps
        self._snapshot()

    def _snapshot(self) -> None:
        rms = self.norm.obs_rms
        assert isinstance(rms, RunningMeanStd)
        self.pool.add(self.model.policy, rms.mean, rms.var, self.num_timesteps)  # type: ignore[arg-type]

    def _on_step(self) -> bool:
        n = self.num_timesteps
        if n >= self.next_save:
            self._snapshot()
            self.next_save += self.ppo.save_steps
        if n >= self.next_swap:
            self.pool.swap()
            self.next_swap += self.ppo.swap_steps
        if n >= self.next_checkpoint:
            save(self.model, self.norm, self.out / "checkpoints" / f"step_{n}")
            self.next_checkpoint += self.ppo.checkpoint_steps
        return True

    def _on_rollout_end(self) -> None:
        self._rollout_end = time.perf_counter()
        self.rollout_s += self._rollout_end - self._rollout_start

    def finish_timing(self) -> None:
        """Count the time since the last rollout (its update) once learning has returned."""
        if self._rollout_end:
            self.update_s += time.perf_counter() - self._rollout_end
            self._rollout_end = 0.0

    def _on_rollout_start(self) -> None:
        self._rollout_start = time.perf_counter()
        if self._rollout_end:
            self.update_s += self._rollout_start - self._rollout_end
        values = self.model.logger.name_to_value
        if "train/value_loss" not in values:
            return
        episodes = list(self.model.ep_info_buffer or ())
        row = {
            "timesteps": self.num_timesteps,
            "wall_s": round(time.perf_counter() - self.start, 2),
            "ep_rew_mean": np.mean([e["r"] for e in episodes]) if episodes else "",
            "ep_len_mean": np.mean([e["l"] for e in episodes]) if episodes else "",
            "value_loss": values.get("train/value_loss", ""),
            "policy_loss": values.get("train/policy_gradient_loss", ""),
            "entropy": values.get("train/entropy_loss", ""),
        }
        log = self.out / LOG
        new = not log.exists()
        with log.open("a", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=LOG_FIELDS)
            if new:
                writer.writeheader()
            writer.writerow(row)


def save(model: BaseAlgorithm, norm: VecNormalize, folder: Path) -> None:
    """The model and its normalisation statistics into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    model.save(folder / MODEL)
    norm.save(str(folder / NORMALISER))


def widen_first_layer(
    w0: np.ndarray, obs_mean: np.ndarray, obs_var: np.ndarray, width: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An actor's first layer and observation statistics for ``width`` inputs, from an actor trained in races of
    fewer karts (:func:`controllers.rl.observations.widened_columns`): the added opponents' columns weighted
    zero (so the actor acts as before) with the first opponent's statistics."""
    karts_from, karts_to = race_karts(w0.shape[1], STACK), race_karts(width, STACK)
    if karts_from is None or karts_to is None:
        raise ValueError(f"cannot widen an actor of {w0.shape[1]} inputs to {width}: no race sizes give those")
    source, added = widened_columns(karts_from, karts_to, STACK)
    wide = w0[:, source].copy()
    wide[:, added] = 0.0
    return wide, obs_mean[source].copy(), obs_var[source].copy()


def load_actor(model: PPO, venv: VecNormalize, folder: Path) -> None:
    """Copy the actor (hidden layers, action head, log std) and the observation statistics of ``folder``'s
    ``policy.npz`` (what :func:`controllers.rl.policy.export_policy` ships) into a fresh ``model`` and ``venv``.
    The critic stays fresh: the shipped agents keep no value network. An actor trained in races of fewer karts
    is widened to the model's (:func:`widen_first_layer`): fine-tuning a shipped agent in fields."""
    with np.load(folder / POLICY_FILE, allow_pickle=False) as data:
        n = int(data["n_layers"])
        state = model.policy.state_dict()
        layers = sorted(
            {int(k.split(".")[2]) for k in state if k.startswith("mlp_extractor.policy_net.") and k.endswith("weight")}
        )
        names = [f"mlp_extractor.policy_net.{i}" for i in layers] + ["action_net"]
        if len(names) != n:
            raise ValueError(f"{folder / POLICY_FILE} has {n} layers, the model {len(names)}")
        arrays = {key: np.asarray(data[key]) for key in data.files}
        obs_mean, obs_var = arrays["obs_mean"].astype(np.float64), arrays["obs_var"].astype(np.float64)
        width = int(state[f"{names[0]}.weight"].shape[1])
        if arrays["w0"].shape[1] < width:  # trained in smaller races: widened to the model's (more opponents)
            arrays["w0"], obs_mean, obs_var = widen_first_layer(arrays["w0"], obs_mean, obs_var, width)
        for i, name in enumerate(names):
            for part, key in (("weight", f"w{i}"), ("bias", f"b{i}")):
                if state[f"{name}.{part}"].shape != arrays[key].shape:
                    raise ValueError(f"{key} of {folder / POLICY_FILE} does not fit the model's {name}.{part}")
                state[f"{name}.{part}"] = torch.as_tensor(arrays[key], dtype=state[f"{name}.{part}"].dtype)
        state["log_std"] = torch.as_tensor(arrays["log_std"], dtype=state["log_std"].dtype)
        model.policy.load_state_dict(state)
        statistics = venv.obs_rms
        assert isinstance(statistics, RunningMeanStd), "a flat (Box) observation space"
        statistics.mean = obs_mean.copy()
        statistics.var = obs_var.copy()
        statistics.count = SHIPPED_STATISTICS_COUNT
        venv.clip_obs = float(data["clip_obs"])


def make_model(venv: VecNormalize, ppo: PPOConfig) -> PPO:
    """A fresh PPO with the spec's settings."""
    n_steps = max(ppo.buffer_size // venv.num_envs, 1)
    return PPO(
        "MlpPolicy",
        venv,
        # a schedule object, not a lambda: cloudpickle stores a lambda's bytecode, and a model saved by another
        # Python version then crashes the loader (a 3.12-trained model segfaulted 3.11's PPO.load)
        learning_rate=LinearSchedule(ppo.learning_rate, 0.0, 1.0),
        n_steps=n_steps,
        batch_size=min(ppo.batch_size, n_steps * venv.num_envs),
        n_epochs=ppo.n_epochs,
        gamma=ppo.gamma,
        gae_lambda=ppo.gae_lambda,
        clip_range=ppo.clip_range,
        ent_coef=ppo.ent_coef,
        policy_kwargs={
            "net_arch": {"pi": list(ppo.hidden), "vf": list(ppo.hidden)},
            "activation_fn": torch.nn.Tanh,
            "log_std_init": ppo.log_std_init,
            # SB3's Adam settings (eps 1e-5) with the multi-tensor update: the same arithmetic bit for bit (checked
            # against the per-tensor loop, which torch picks by default on the CPU) at a fraction of the Python
            # overhead per gradient step
            "optimizer_kwargs": {"eps": 1e-5, "foreach": True},
        },
        seed=ppo.seed,
        device="cpu",
        verbose=0,
    )


def train(
    env: EnvConfig,
    ppo: PPOConfig,
    out: Path,
    *,
    resume: bool = False,
    progress_bar: bool = False,
    fine_tune_from: Path | None = None,
) -> TrainResult:
    """Train ``env.agent`` to ``ppo.total_steps`` environment steps (resuming from ``out`` when asked and a
    model is there), write the model, statistics, log and curves into ``out``.

    ``fine_tune_from``: start from that folder's model and normalisation statistics instead of a fresh policy,
    with a fresh step count and learning-rate schedule (``ppo.total_steps`` more steps, e.g. on a changed
    training set)."""
    torch.set_num_threads(ppo.torch_threads)
    out.mkdir(parents=True, exist_ok=True)
    pool = OpponentPool(ppo.window, ppo.play_against_latest, ppo.seed + 1)
    raw = SelfPlayVecEnv(RaceBatch(env, ppo.n_races), pool)
    raw.seed(ppo.seed)
    resuming = resume and (out / MODEL).exists()
    source = out if resuming else fine_tune_from
    if source is not None and not (source / MODEL).exists() and (source / POLICY_FILE).exists():
        # a shipped agent (inference files only): its actor and observation statistics, a fresh critic
        (out / LOG).unlink(missing_ok=True)
        venv = VecNormalize(raw, norm_obs=True, norm_reward=ppo.normalise_reward, clip_obs=10.0, gamma=ppo.gamma)
        model = make_model(venv, ppo)
        load_actor(model, venv, source)
    elif source is not None:
        venv = VecNormalize.load(str(source / NORMALISER), raw)
        venv.training = True
        schedule = LinearSchedule(ppo.learning_rate, 0.0, 1.0)
        model = PPO.load(
            source / MODEL, env=venv, device="cpu", custom_objects={"learning_rate": schedule, "lr_schedule": schedule}
        )
        if not resuming:
            (out / LOG).unlink(missing_ok=True)
            model.num_timesteps = 0
    else:
        (out / LOG).unlink(missing_ok=True)
        venv = VecNormalize(raw, norm_obs=True, norm_reward=ppo.normalise_reward, clip_obs=10.0, gamma=ppo.gamma)
        model = make_model(venv, ppo)
    record_settings(out, env, ppo, resumed=resuming, fine_tune_from=fine_tune_from, start_steps=model.num_timesteps)
    callback = SelfPlayCallback(pool, venv, ppo, out)
    remaining = max(ppo.total_steps - model.num_timesteps, 0)
    start_steps, start = model.num_timesteps, time.perf_counter()
    if remaining:
        model.learn(remaining, callback=callback, reset_num_timesteps=not resuming, progress_bar=progress_bar)
        callback.finish_timing()
    wall = time.perf_counter() - start
    save(model, venv, out)
    if (out / LOG).exists():
        plot_curves(out / LOG, out / CURVES, title=f"{env.agent}: PPO self-play")
    done = model.num_timesteps - start_steps
    rate = done / wall if wall > 0 else 0.0
    return TrainResult(out, model.num_timesteps, wall, rate, callback.rollout_s, callback.update_s)


def record_settings(
    out: Path, env: EnvConfig, ppo: PPOConfig, *, resumed: bool, fine_tune_from: Path | None, start_steps: int
) -> None:
    """Add this run's settings (environment, reward weights, PPO) to ``out``'s :data:`SETTINGS` file: a fresh
    list unless the run resumes the model there, so a trained folder says what it was trained with."""
    path = out / SETTINGS
    runs = json.loads(path.read_text()) if resumed and path.exists() else []
    runs.append(
        {
            "started": datetime.now(UTC).isoformat(timespec="seconds"),
            "start_steps": int(start_steps),
            "resumed": resumed,
            "fine_tune_from": None if fine_tune_from is None or resumed else str(fine_tune_from),
            "env": asdict(env),
            "ppo": asdict(ppo),
        }
    )
    path.write_text(json.dumps(runs, indent=2) + "\n")


def policy_actions(model: PPO, norm: VecNormalize, deterministic: bool = True) -> Callable[[np.ndarray], np.ndarray]:
    """A function from raw observations (n, D) to actions (n, 2) of a trained model."""

    def act(obs: np.ndarray) -> np.ndarray:
        actions, _ = model.predict(norm.normalize_obs(obs.astype(np.float32)), deterministic=deterministic)
        return np.clip(actions, -1.0, 1.0)

    return act


def mean_decision_reward(
    env: EnvConfig, act: Callable[[np.ndarray], np.ndarray], n_races: int, decisions: int, seed: int
) -> float:
    """Mean reward per decision of kart 0 driven by ``act`` (the other karts random), over seeded spawns."""
    batch = RaceBatch(env, n_races, seed=seed)
    obs = batch.reset()
    rng = np.random.default_rng(seed + 1)
    total = 0.0
    for _ in range(decisions):
        joint = rng.uniform(-1.0, 1.0, (n_races, batch.n_karts, 2))
        joint[:, 0] = act(obs[:, 0])
        result = batch.step(joint)
        obs = result.obs
        total += float(result.reward[:, 0].mean())
    return total / decisions
