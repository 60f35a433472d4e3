"""A trained agent's policy for inference: the PPO actor's mean action, in numpy, from a weights folder.

The trainer (:mod:`controllers.rl.train`) writes Stable-Baselines3 files (``model.zip``, ``vecnormalize.pkl``);
:func:`export_policy` turns them into ``policy.npz``: the actor's layers (3x128 tanh, then the linear action
head), the running observation mean and variance and the clip of the normaliser. Inference reads only that
file (``numpy.load`` without pickles), so a controller host needs neither torch nor Stable-Baselines3 and a
decision costs a few microseconds of matrix products. Torch is imported by :func:`export_policy` alone.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

from controllers.rl.actions import most_probable_pedal_of

POLICY_FILE = "policy.npz"
WEIGHTS_ROOT = Path(__file__).resolve().parent / "weights"
NORM_EPSILON = 1e-8  # VecNormalize's epsilon


def weights_folder(agent: str) -> Path:
    """The shipped weights folder of ``agent`` (``controllers/rl/weights/AGENT``)."""
    return WEIGHTS_ROOT / agent


class MissingWeightsError(FileNotFoundError):
    """An RL agent was asked to drive but its weights folder holds no ``policy.npz``."""


@dataclass(frozen=True)
class Policy:
    """The trained actor: a Gaussian over ``[steer, pedal]`` (:meth:`act` samples it or decides by it)."""

    weights: tuple[np.ndarray, ...]  # per layer (out, in)
    biases: tuple[np.ndarray, ...]
    obs_mean: np.ndarray
    obs_var: np.ndarray
    clip_obs: float
    log_std: np.ndarray  # (2,) the Gaussian's state-independent log standard deviation

    @property
    def obs_size(self) -> int:
        """Floats in one (stacked) observation."""
        return int(self.obs_mean.shape[0])

    def normalise(self, obs: np.ndarray) -> np.ndarray:
        """The trainer's observation normalisation (running mean and variance, clipped)."""
        z = (obs - self.obs_mean) / self._obs_scale
        return np.clip(z, -self.clip_obs, self.clip_obs)

    @cached_property
    def _obs_scale(self) -> np.ndarray:
        return np.sqrt(self.obs_var + NORM_EPSILON)

    @cached_property
    def _std(self) -> tuple[float, float]:
        steer, pedal = np.exp(self.log_std)
        return float(steer), float(pedal)

    def act(self, obs: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """(2,) ``[steer, pedal]`` in [-1, 1] for one raw observation (D,): a sample from the Gaussian with
        ``rng`` (as PPO's training rollouts act), else its mean steer with the pedal branch the Gaussian most
        likely picks (:func:`controllers.rl.actions.most_probable_pedal`)."""
        if rng is not None:
            return self.sample(obs, rng)
        steer, pedal = self.mean(obs).tolist()
        return np.array([min(max(steer, -1.0), 1.0), most_probable_pedal_of(pedal, self._std[1])])

    def mean(self, obs: np.ndarray) -> np.ndarray:
        """(2,) the action distribution's mean (unclipped); (n, 2) for a batch (n, D) of observations."""
        h = self.normalise(np.asarray(obs, dtype=np.float64))
        last = len(self.weights) - 1
        batched = h.ndim > 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = (h @ w.T if batched else w @ h) + b
            if i < last:
                h = np.tanh(h)
        return h

    def sample(self, obs: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Actions in [-1, 1], (2,) for one raw observation (D,) or (n, 2) for a batch (n, D): samples of the
        Gaussian, as PPO's rollouts act (the self-play opponents drive this way)."""
        mean = self.mean(obs)
        return np.clip(mean + np.exp(self.log_std) * rng.standard_normal(mean.shape), -1.0, 1.0)


def policy_from_state(
    state: Mapping[str, np.ndarray], obs_mean: np.ndarray, obs_var: np.ndarray, clip_obs: float
) -> Policy:
    """The actor of a Stable-Baselines3 ``ActorCriticPolicy`` from its state dict (as numpy arrays) and the
    observation statistics it was trained under."""
    layers = sorted(
        {int(k.split(".")[2]) for k in state if k.startswith("mlp_extractor.policy_net.") and k.endswith("weight")}
    )
    names = [f"mlp_extractor.policy_net.{i}" for i in layers] + ["action_net"]
    return Policy(
        tuple(np.asarray(state[f"{name}.weight"]) for name in names),
        tuple(np.asarray(state[f"{name}.bias"]) for name in names),
        np.asarray(obs_mean, dtype=np.float64),
        np.asarray(obs_var, dtype=np.float64),
        float(clip_obs),
        np.asarray(state["log_std"]),
    )


def load_policy(folder: Path | str) -> Policy:
    """The policy in ``folder`` (its ``policy.npz``); :class:`MissingWeightsError` says how to make one."""
    return _load(str(Path(folder).resolve()))


@lru_cache(maxsize=8)
def _load(folder: str) -> Policy:
    path = Path(folder) / POLICY_FILE
    if not path.exists():
        raise MissingWeightsError(
            f"no trained weights at {path}: train the agent (karting train AGENT --out FOLDER) and export them "
            "(python -m controllers.rl.policy FOLDER), or use the shipped controllers/rl/weights/AGENT"
        )
    with np.load(path, allow_pickle=False) as data:
        n = int(data["n_layers"])
        # stored in float32, held in float64: numpy would cast them on every product anyway (the same numbers,
        # so the same results, without a copy of every layer per decision)
        return Policy(
            tuple(data[f"w{i}"].astype(np.float64) for i in range(n)),
            tuple(data[f"b{i}"].astype(np.float64) for i in range(n)),
            data["obs_mean"],
            data["obs_var"],
            float(data["clip_obs"]),
            data["log_std"],
        )


INFERENCE_ONLY = {"learning_rate": 0.0, "lr_schedule": lambda _: 0.0, "clip_range": lambda _: 0.0}


def export_policy(folder: Path | str, out: Path | str | None = None) -> Path:
    """Write ``policy.npz`` (into ``out``, default ``folder``) from the trainer's ``model.zip`` and
    ``vecnormalize.pkl`` in ``folder``."""
    import pickle

    from stable_baselines3 import PPO

    folder = Path(folder)
    target = Path(out) if out is not None else folder
    target.mkdir(parents=True, exist_ok=True)
    # the schedules are not needed for inference; skipping them also loads models saved by another Python
    model = PPO.load(folder / "model.zip", device="cpu", custom_objects=INFERENCE_ONLY)
    state = {k: v.detach().cpu().numpy().astype(np.float32) for k, v in model.policy.state_dict().items()}
    with (folder / "vecnormalize.pkl").open("rb") as fh:
        norm = pickle.load(fh)  # the trainer's own file (trusted); SB3 saves VecNormalize by pickle
    policy = policy_from_state(state, norm.obs_rms.mean, norm.obs_rms.var, norm.clip_obs)
    arrays: dict[str, np.ndarray] = {
        "n_layers": np.array(len(policy.weights)),
        "obs_mean": policy.obs_mean,
        "obs_var": policy.obs_var,
        "clip_obs": np.array(policy.clip_obs),
        "log_std": policy.log_std,
    }
    for i, (w, b) in enumerate(zip(policy.weights, policy.biases)):
        arrays[f"w{i}"] = w
        arrays[f"b{i}"] = b
    path = target / POLICY_FILE
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]
    return path


if __name__ == "__main__":
    import sys

    print(export_policy(*sys.argv[1:3]))
