"""The training races as RL-ecosystem environments (no torch here):

* :class:`KartRaceEnv`: a Gymnasium ``Env``, one race, the learning kart 0 against opponents driven by a
  policy function (random by default);
* :class:`KartRaceVectorEnv`: a Gymnasium ``VectorEnv`` over the batched World, many races in one compiled
  step per track, reset in the same step (``final_obs`` in the infos);
* :class:`KartRaceParallelEnv`: a PettingZoo ``ParallelEnv``, one agent per kart (``kart_0``, ``kart_1``...).

Registered with Gymnasium on import as ``karting/KartRace-v0`` (kwargs: ``agent``, ``tracks``, ``n_karts``...)
and one id per agent, ``karting/KartRace-MCTSRL-v0``, ``-FixedRL-v0``, ``-E2E-v0``::

    import gymnasium as gym
    env = gym.make("controllers.rl.envs:karting/KartRace-MCTSRL-v0")           # one race
    envs = gym.make_vec("controllers.rl.envs:karting/KartRace-v0", num_envs=64,
                        vectorization_mode="vector_entry_point", agent="e2e")  # 64 races, one step call
    from controllers.rl.envs import parallel_env
    race = parallel_env(agent="fixed-rl")                                     # PettingZoo, both karts
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from pettingzoo import ParallelEnv

from controllers.rl.batch import RaceBatch
from controllers.rl.config import TRAINING_TRACKS, AgentKind, EnvConfig, agent_kind, reward_weights
from sim_core import state as st

Opponent = Callable[[np.ndarray], np.ndarray]  # (n, D) observations -> (n, 2) actions


def make_config(agent: str = "mcts-rl", tracks: tuple[str, ...] | None = None, **overrides: Any) -> EnvConfig:
    """An :class:`EnvConfig` for ``agent`` (its reward weights) with field overrides."""
    kind: AgentKind = agent_kind(agent)
    config = EnvConfig(agent=kind, weights=reward_weights(kind), tracks=tuple(tracks or TRAINING_TRACKS))
    return replace(config, **overrides)


def observation_space(batch: RaceBatch) -> gym.spaces.Box:
    """One kart's stacked observation."""
    return gym.spaces.Box(-np.inf, np.inf, (batch.obs_size,), np.float32)


def action_space() -> gym.spaces.Box:
    """``[steer, pedal]`` in [-1, 1] (see :mod:`controllers.rl.actions`)."""
    return gym.spaces.Box(-1.0, 1.0, (2,), np.float32)


class RandomOpponent:
    """Uniform random actions from its own seeded generator."""

    def __init__(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """Random actions for ``obs`` (n, D)."""
        return self.rng.uniform(-1.0, 1.0, (obs.shape[0], 2))


def joint_actions(batch: RaceBatch, obs: np.ndarray, learner: np.ndarray, opponent: Opponent) -> np.ndarray:
    """(B, K, 2) with kart 0 the learner's ``learner`` (B, 2) and the others ``opponent`` of their views."""
    joint = np.empty((batch.n_races, batch.n_karts, 2))
    joint[:, 0] = learner
    if batch.n_karts > 1:
        others = obs[:, 1:].reshape(-1, obs.shape[-1]).astype(np.float32)
        joint[:, 1:] = np.asarray(opponent(others)).reshape(batch.n_races, batch.n_karts - 1, 2)
    return joint


class KartRaceEnv(gym.Env[np.ndarray, np.ndarray]):
    """One training race (Gymnasium): the learner drives kart 0; ``opponent`` drives the others."""

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012

    def __init__(self, agent: str = "mcts-rl", opponent: Opponent | None = None, **config: Any) -> None:
        self.batch = RaceBatch(make_config(agent, **config), 1, autoreset=False)
        self.opponent = opponent
        self._own_opponent = opponent is None
        self.observation_space = observation_space(self.batch)
        self.action_space = action_space()
        self._obs = np.zeros((1, self.batch.n_karts, self.batch.obs_size))

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """A new random spawn."""
        super().reset(seed=seed)
        batch_seed = int(self.np_random.integers(2**31))
        if self._own_opponent:
            self.opponent = RandomOpponent(batch_seed + 1)
        self._obs = self.batch.reset(batch_seed)
        return self._obs[0, 0].astype(np.float32), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        """One decision (2 physics steps)."""
        assert self.opponent is not None, "reset() first"
        joint = joint_actions(self.batch, self._obs, np.asarray(action).reshape(1, 2), self.opponent)
        result = self.batch.step(joint)
        self._obs = result.obs
        terminated = bool(self.batch.blocks[0].world.istate[0, 0, st.I_FINISHED])
        truncated = bool(result.ended[0]) and not terminated
        return result.obs[0, 0].astype(np.float32), float(result.reward[0, 0]), terminated, truncated, {}


class KartRaceVectorEnv(VectorEnv):
    """``num_envs`` training races stepped together (Gymnasium vector API, same-step autoreset)."""

    metadata: dict[str, Any] = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}  # noqa: RUF012

    def __init__(
        self, num_envs: int = 64, agent: str = "mcts-rl", opponent: Opponent | None = None, **config: Any
    ) -> None:
        self.batch = RaceBatch(make_config(agent, **config), num_envs, autoreset=True)
        self.num_envs = num_envs
        self.opponent: Opponent = opponent or RandomOpponent()
        self.single_observation_space = observation_space(self.batch)
        self.single_action_space = action_space()
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, num_envs)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, num_envs)
        self._obs = np.zeros((num_envs, self.batch.n_karts, self.batch.obs_size))
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=np.int64)

    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Spawn every race anew."""
        first = seed[0] if isinstance(seed, list) else seed
        if first is not None and isinstance(self.opponent, RandomOpponent):
            self.opponent = RandomOpponent(first + 1)
        self._obs = self.batch.reset(first)
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return self._obs[:, 0].astype(np.float32), {}

    def step(self, actions: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray, dict]:
        """One decision of every race; ended races come back reset, their last view in ``infos["final_obs"]``."""
        joint = joint_actions(self.batch, self._obs, np.asarray(actions).reshape(self.num_envs, 2), self.opponent)
        result = self.batch.step(joint)
        self._obs = result.obs
        reward = result.reward[:, 0]
        self._returns += reward
        self._lengths += 1
        terminated = result.finished[:, 0]
        truncated = result.ended & ~terminated
        infos: dict[str, Any] = {}
        if result.ended.any():
            final = np.empty(self.num_envs, dtype=object)
            for b in np.flatnonzero(result.ended):
                final[b] = result.final_obs[b, 0].astype(np.float32)
            infos = {
                "final_obs": final,
                "_final_obs": result.ended.copy(),
                "episode": {"r": np.where(result.ended, self._returns, 0.0), "l": self._lengths.copy()},
                "_episode": result.ended.copy(),
            }
            self._returns[result.ended] = 0.0
            self._lengths[result.ended] = 0
        return self._obs[:, 0].astype(np.float32), reward, terminated, truncated, infos


class KartRaceParallelEnv(ParallelEnv):
    """One training race with every kart an agent (PettingZoo parallel API)."""

    metadata: dict[str, Any] = {"name": "karting_race_v0", "render_modes": []}  # noqa: RUF012

    def __init__(self, agent: str = "mcts-rl", **config: Any) -> None:
        self.batch = RaceBatch(make_config(agent, **config), 1, autoreset=False, learner_ends=False)
        self.possible_agents = [f"kart_{k}" for k in range(self.batch.n_karts)]
        self.agents: list[str] = []
        self._obs_space = observation_space(self.batch)
        self._act_space = action_space()
        self._obs = np.zeros((1, self.batch.n_karts, self.batch.obs_size))

    def observation_space(self, agent: str) -> gym.spaces.Box:
        """Every kart's observation space (the same object)."""
        return self._obs_space

    def action_space(self, agent: str) -> gym.spaces.Box:
        """Every kart's action space (the same object)."""
        return self._act_space

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """A new random spawn for every kart."""
        self._obs = self.batch.reset(seed)
        self.agents = list(self.possible_agents)
        obs = {a: self._obs[0, k].astype(np.float32) for k, a in enumerate(self.possible_agents)}
        return obs, {a: {} for a in self.agents}

    def step(self, actions: dict[str, np.ndarray]) -> tuple[dict, dict, dict, dict, dict]:
        """One decision; karts that finished or ran out of time leave ``agents``."""
        joint = np.zeros((1, self.batch.n_karts, 2))
        for k, a in enumerate(self.possible_agents):
            if a in actions:
                joint[0, k] = actions[a]
        result = self.batch.step(joint)
        self._obs = result.obs
        index = {a: k for k, a in enumerate(self.possible_agents)}
        obs = {a: self._obs[0, index[a]].astype(np.float32) for a in self.agents}
        rewards = {a: float(result.reward[0, index[a]]) for a in self.agents}
        term = {a: bool(self.batch.blocks[0].world.istate[0, index[a], st.I_FINISHED]) for a in self.agents}
        trunc = {a: bool(result.ended[0]) and not term[a] for a in self.agents}
        infos: dict[str, dict] = {a: {} for a in self.agents}
        self.agents = [a for a in self.agents if not (term[a] or trunc[a])]
        return obs, rewards, term, trunc, infos


def parallel_env(agent: str = "mcts-rl", **config: Any) -> KartRaceParallelEnv:
    """The PettingZoo environment (the ecosystem's ``parallel_env`` convention)."""
    return KartRaceParallelEnv(agent, **config)


def register_envs() -> None:
    """Register the Gymnasium ids (idempotent)."""
    ids: dict[str, dict[str, str]] = {"karting/KartRace-v0": {}}
    ids.update(
        {
            f"karting/KartRace-{tag}-v0": {"agent": a}
            for tag, a in (("MCTSRL", "mcts-rl"), ("FixedRL", "fixed-rl"), ("E2E", "e2e"))
        }
    )
    for env_id, kwargs in ids.items():
        if env_id not in gym.registry:
            gym.register(
                env_id,
                entry_point="controllers.rl.envs:KartRaceEnv",
                vector_entry_point="controllers.rl.envs:KartRaceVectorEnv",
                kwargs=kwargs,
            )


register_envs()
