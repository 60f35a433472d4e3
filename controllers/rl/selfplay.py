"""Self-play for Stable-Baselines3 (torch): the training races as an SB3 ``VecEnv`` whose kart 0 is the learner
and whose other karts are driven by a frozen past policy from a pool (ML-Agents' self-play settings: a window
of 10 snapshots taken every ``save_steps``, the opponent swapped every ``swap_steps``, half the time to the
latest snapshot).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from controllers.rl.batch import RaceBatch
from controllers.rl.envs import action_space, joint_actions, observation_space
from controllers.rl.policy import Policy, policy_from_state

CLIP_OBS = 10.0


@dataclass
class Snapshot:
    """A frozen policy's actor (numpy, with the observation statistics it was trained under) and a float32 torch
    view of its layers for driving a batch of opponents."""

    policy: Policy
    steps: int
    layers: tuple[tuple[torch.Tensor, torch.Tensor], ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # the tensors share the numpy copy's memory (float32, as the state dict it came from)
        self.layers = tuple(
            (torch.from_numpy(np.ascontiguousarray(w, dtype=np.float32)), torch.from_numpy(np.asarray(b, np.float32)))
            for w, b in zip(self.policy.weights, self.policy.biases)
        )

    def mean(self, obs: np.ndarray) -> np.ndarray:
        """(n, 2) the actor's mean actions for raw observations ``obs`` (n, D): normalised as
        :meth:`Policy.normalise` (float64), then the layers in float32, as the live torch policy computes them.

        Torch rather than numpy for the products: torch keeps to the trainer's thread count, where numpy's
        OpenBLAS starts a thread per core and, on a machine busy with other work, its threads waiting on each
        other made a 128-race batch 35x slower (70 ms against 2 ms, measured on 2 cores)."""
        z = self.policy.normalise(obs).astype(np.float32)
        last = len(self.layers) - 1
        with torch.no_grad():
            h = torch.from_numpy(z)
            for i, (w, b) in enumerate(self.layers):
                h = torch.nn.functional.linear(h, w, b)
                if i < last:
                    h = torch.tanh_(h)
            return h.numpy()


class OpponentPool:
    """Frozen past policies; :meth:`__call__` drives the opponents with the current one (stochastic)."""

    def __init__(self, window: int, latest_ratio: float, seed: int) -> None:
        self.window = window
        self.latest_ratio = latest_ratio
        self.rng = np.random.default_rng(seed)
        self.snapshots: list[Snapshot] = []
        self.current: Snapshot | None = None

    def add(self, policy: ActorCriticPolicy, mean: np.ndarray, var: np.ndarray, steps: int) -> None:
        """Freeze ``policy``'s actor as it is now (keeping the last ``window``). The opponents drive by a copy of the
        actor alone: the live torch policy's forward would also run the critic."""
        state = {k: v.detach().cpu().numpy().copy() for k, v in policy.state_dict().items()}
        self.snapshots.append(Snapshot(policy_from_state(state, mean.copy(), var.copy(), CLIP_OBS), steps))
        self.snapshots = self.snapshots[-self.window :]
        if self.current is None:
            self.current = self.snapshots[-1]

    def swap(self) -> Snapshot:
        """Pick the next opponent: the latest with probability ``latest_ratio``, else one from the window."""
        if self.rng.random() < self.latest_ratio:
            self.current = self.snapshots[-1]
        else:
            self.current = self.snapshots[int(self.rng.integers(len(self.snapshots)))]
        return self.current

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """Actions of the current opponent for raw observations ``obs`` (n, D): samples of its Gaussian (the draws
        of :meth:`Policy.sample`)."""
        assert self.current is not None, "add() a policy first"
        mean = self.current.mean(obs)
        noise = np.exp(self.current.policy.log_std) * self.rng.standard_normal(mean.shape)
        return np.clip(mean + noise, -1.0, 1.0)


class SelfPlayVecEnv(VecEnv):
    """The training races for SB3: one learning kart per race (kart 0), the others driven by ``opponent``."""

    def __init__(self, batch: RaceBatch, opponent: Any) -> None:
        self.render_mode = None
        super().__init__(batch.n_races, observation_space(batch), action_space())
        self.batch = batch
        self.opponent = opponent
        self._obs = np.zeros((batch.n_races, batch.n_karts, batch.obs_size))
        self._actions = np.zeros((batch.n_races, 2))
        self._returns = np.zeros(batch.n_races)
        self._lengths = np.zeros(batch.n_races, dtype=np.int64)

    def reset(self) -> np.ndarray:
        """Spawn every race (seeded by :meth:`seed` once, then continuing the batch's generator)."""
        seed = self._seeds[0] if self._seeds and self._seeds[0] is not None else None
        self._reset_seeds()
        self._obs = self.batch.reset(seed)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return self._obs[:, 0].astype(np.float32)

    def step_async(self, actions: np.ndarray) -> None:
        """Remember the learner's actions."""
        self._actions = np.asarray(actions).reshape(self.num_envs, 2)

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        """One decision of every race, ended races reset (``terminal_observation`` and Monitor-style
        ``episode`` in their infos)."""
        result = self.batch.step(joint_actions(self.batch, self._obs, self._actions, self.opponent))
        self._obs = result.obs
        reward = result.reward[:, 0]
        self._returns += reward
        self._lengths += 1
        infos: list[dict] = [{} for _ in range(self.num_envs)]
        for b in np.flatnonzero(result.ended):
            infos[b] = {
                "terminal_observation": result.final_obs[b, 0].astype(np.float32),
                "TimeLimit.truncated": bool(result.truncated[b]) and not bool(result.finished[b, 0]),
                "episode": {"r": float(self._returns[b]), "l": int(self._lengths[b]), "t": 0.0},
            }
        self._returns[result.ended] = 0.0
        self._lengths[result.ended] = 0
        return self._obs[:, 0].astype(np.float32), reward.astype(np.float32), result.ended.copy(), infos

    def close(self) -> None:
        """Nothing to release."""

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """The batch's attribute, once per race."""
        return [getattr(self.batch, attr_name)] * len(list(self._get_indices(indices)))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set a batch attribute."""
        setattr(self.batch, attr_name, value)

    def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> list[Any]:
        """Call a batch method once."""
        return [getattr(self.batch, method_name)(*args, **kwargs)]

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """No gym wrappers inside."""
        return [False] * len(list(self._get_indices(indices)))
