"""Many training races at once: Worlds (one per training track) stepped a decision at a time, with the
observations and rewards of every kart, random spawns, and same-step reset of the races that ended.

:class:`RaceBatch` is what the Gymnasium and PettingZoo environments (:mod:`controllers.rl.envs`) and the
trainer wrap. A decision holds the action for 2 physics steps (25 Hz) in one compiled call per track.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from controllers.rl import rewards as rw
from controllers.rl.actions import ACCELERATE, world_actions
from controllers.rl.config import DECISION_STEPS, STACK, EnvConfig
from controllers.rl.observations import (
    TrackTables,
    build_frame,
    frame_size,
    place_phantoms,
)
from controllers.rl.spawns import random_plan, spawn_race
from sim_core import state as st
from sim_core.params import DT, RuleParams, SimParams, kart_preset
from sim_core.track_io import get_track
from sim_core.world import World


@dataclass
class Block:
    """The races on one track and their episode bookkeeping."""

    world: World
    tables: TrackTables
    plan_lane: np.ndarray  # (b, K, N) target lane per checkpoint, 0 = centre
    plan_speed: np.ndarray  # (b, K, N) [m/s]
    reach_count: np.ndarray  # (b, M) karts that reached absolute checkpoint m - 1
    first_time: np.ndarray  # (b, M) [s] when the first did
    passed: np.ndarray  # (b, K) checkpoints passed at the last decision
    illegal: np.ndarray  # (b, K) per-step illegal lane changes at the last decision
    since: np.ndarray  # (b, K) [m] from the last checkpoint passed, at the last decision
    accelerating: np.ndarray  # (b, K) 1.0 while on the accelerator
    stack: np.ndarray  # (b, K, STACK, frame)
    absent: np.ndarray  # (b, K) bool: shown as finished phantoms behind kart 0 (EnvConfig.solo_probability)
    offset: int = 0  # index of this block's first race in the batch
    terms: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class StepResult:
    """What one decision of every race gave. ``obs`` is after any reset; ``final_obs`` holds the last
    observation of the races that ended (rows of the others are stale)."""

    obs: np.ndarray  # (B, K, D)
    reward: np.ndarray  # (B, K)
    finished: np.ndarray  # (B, K) the kart finished this decision (terminated)
    ended: np.ndarray  # (B,) the episode of the race ended (and the race was reset when autoreset)
    truncated: np.ndarray  # (B,) it ended on the episode's time limit
    final_obs: np.ndarray  # (B, K, D)


class RaceBatch:
    """B races of K karts spread over the configured tracks. ``step`` takes (B, K, 2) actions in [-1, 1]."""

    def __init__(
        self,
        config: EnvConfig,
        n_races: int,
        seed: int | None = None,
        *,
        autoreset: bool = True,
        learner_ends: bool = True,
    ) -> None:
        self.config = config
        self.learner_ends = learner_ends  # a race ends when kart 0 finishes (else when every kart has)
        self.n_races = n_races
        self.n_karts = config.n_karts
        self.autoreset = autoreset
        self.kart = kart_preset(config.kart_preset)
        self.params = SimParams(kart=self.kart, rules=RuleParams(time_limit=config.episode_steps * DT + 10.0))
        self.horizon = config.episode_steps * DT  # [s] T of the rewards
        self.frame = frame_size(self.n_karts)
        self.obs_size = STACK * self.frame
        self.rng = np.random.default_rng(seed)
        counts = [n_races // len(config.tracks) + (t < n_races % len(config.tracks)) for t in range(len(config.tracks))]
        self.blocks: list[Block] = []
        offset = 0
        for name, count in zip(config.tracks, counts):
            if count:
                self.blocks.append(self._block(name, count, offset))
                offset += count
        self.step_count = np.zeros(n_races, dtype=np.int64)  # decisions in the current episode

    def _block(self, name: str, count: int, offset: int) -> Block:
        track = get_track(name)
        world = World(track, n_races=count, n_karts=self.n_karts, params=self.params, laps=2)
        n, k = track.n_checkpoints, self.n_karts
        m = 2 * n + 3
        return Block(
            world=world,
            tables=TrackTables.of(track),
            plan_lane=np.zeros((count, k, n), dtype=np.int64),
            plan_speed=np.full((count, k, n), self.kart.top_speed),
            reach_count=np.zeros((count, m), dtype=np.int64),
            first_time=np.zeros((count, m)),
            passed=np.zeros((count, k), dtype=np.int64),
            illegal=np.zeros((count, k), dtype=np.int64),
            since=np.zeros((count, k)),
            accelerating=np.zeros((count, k)),
            stack=np.zeros((count, k, STACK, self.frame)),
            absent=np.zeros((count, k), dtype=bool),
            offset=offset,
        )

    # ------------------------------------------------------------------ episodes
    def reset(self, seed: int | None = None) -> np.ndarray:
        """Spawn every race anew; (B, K, D) observations."""
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        for block in self.blocks:
            self._spawn(block, np.arange(block.world.n_races))
        self.step_count[:] = 0
        return self.observations()

    def _spawn(self, block: Block, races: np.ndarray) -> None:
        w = block.world
        for b in races:
            cps = spawn_race(w, int(b), self.config, self.rng)
            block.absent[b] = False
            # (no draw when off: older seeded runs replay)
            if self.config.solo_probability > 0.0 and self.rng.random() < self.config.solo_probability:
                block.absent[b, 1:] = True
            for k in range(self.n_karts):
                block.plan_lane[b, k], block.plan_speed[b, k] = random_plan(
                    self.config, w.track, self.kart.top_speed, self.rng
                )
            # the leader's checkpoints are already reached (earlier, at random times) when the others get there
            block.reach_count[b] = 0
            block.first_time[b] = 0.0
            lead, behind = int(cps.max()), int(cps.min())
            for c in range(behind + 1, lead + 1):
                block.reach_count[b, c + 1] = 1
                block.first_time[b, c + 1] = -self.rng.uniform(0.0, self.config.max_behind_time)
        place_phantoms(w.fstate, w.istate, block.absent)
        self._sense(block, races)
        f, i = w.fstate[races], w.istate[races]
        block.passed[races] = i[:, :, st.I_CP_PASSED]
        block.illegal[races] = i[:, :, st.I_ILLEGAL_STEP]
        block.since[races] = self._since(block, f, i)
        block.accelerating[races] = 0.0
        frame = self._frame(block)[races]
        block.stack[races] = frame[:, :, None, :]

    def _sense(self, block: Block, races: np.ndarray) -> None:
        block.world.sense(races)  # only the races that were reset

    @staticmethod
    def _since(block: Block, f: np.ndarray, i: np.ndarray) -> np.ndarray:
        t = block.tables
        last = np.mod(i[:, :, st.I_CP_PASSED], t.n_checkpoints)
        return np.mod(f[:, :, st.F_S] - t.checkpoint_s[last], t.length)

    def _frame(self, block: Block) -> np.ndarray:
        w = block.world
        return build_frame(
            w, block.tables, block.plan_lane, block.plan_speed, block.accelerating, w.time / self.horizon
        )

    def observations(self) -> np.ndarray:
        """(B, K, STACK * frame) the stacked observations now."""
        return np.concatenate([b.stack.reshape(b.stack.shape[0], self.n_karts, -1) for b in self.blocks])

    # ------------------------------------------------------------------ stepping
    def step(self, actions: np.ndarray) -> StepResult:
        """One decision of every race: hold ``actions`` (B, K, 2) for 2 physics steps, score, observe."""
        actions = np.asarray(actions, dtype=float).reshape(self.n_races, self.n_karts, 2)
        reward = np.zeros((self.n_races, self.n_karts))
        finished = np.zeros((self.n_races, self.n_karts), dtype=bool)
        ended = np.zeros(self.n_races, dtype=bool)
        truncated = np.zeros(self.n_races, dtype=bool)
        self.step_count += 1
        # the action map once for every race (one call instead of one per track: this loop's cost is per call)
        speeds = np.concatenate([block.world.fstate[:, :, st.F_SPEED] for block in self.blocks])
        inputs, branch = world_actions(self.kart, speeds, actions)
        for block in self.blocks:
            sl = slice(block.offset, block.offset + block.world.n_races)
            reward[sl], finished[sl] = self._advance(block, inputs[sl], branch[sl])
            block.stack[:, :, :-1] = block.stack[:, :, 1:]
            block.stack[:, :, -1] = self._frame(block)
            truncated[sl] = block.world.steps >= self.config.episode_steps
            done_karts = block.world.istate[:, :, st.I_FINISHED].astype(bool)
            ended[sl] = truncated[sl] | block.world.done | done_karts.all(axis=1)
            if self.learner_ends:
                ended[sl] |= done_karts[:, 0]
        obs = self.observations()
        final_obs = obs.copy() if ended.any() else obs
        if self.autoreset and ended.any():
            for block in self.blocks:
                races = np.flatnonzero(ended[block.offset : block.offset + block.world.n_races])
                if races.size:
                    self._spawn(block, races)
            self.step_count[ended] = 0
            obs = self.observations()
        return StepResult(obs, reward, finished, ended, truncated & ended, final_obs)

    def _advance(self, block: Block, inputs: np.ndarray, branch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = block.world
        f, i = w.fstate, w.istate
        active = i[:, :, st.I_FINISHED] == 0
        block.accelerating = (branch == ACCELERATE).astype(float)
        w.step(inputs, n_steps=DECISION_STEPS)
        if block.absent.any():
            place_phantoms(f, i, block.absent)
            block.accelerating[block.absent] = 0.0
        reward = self._step_terms(block, active) + self._checkpoint_terms(block, active)
        finished = active & (i[:, :, st.I_FINISHED] == 1)
        return reward, finished

    def _step_terms(self, block: Block, active: np.ndarray) -> np.ndarray:
        """Per-physics-step terms (times the 2 steps a decision holds) and the per-decision ray checks."""
        w = block.world
        terms, total = rw.decision_terms(
            self.config.weights, self.kart.top_speed, w, block.tables.points, block.plan_lane, block.accelerating,
            active, block.illegal,
        )  # fmt: skip
        block.illegal = w.istate[:, :, st.I_ILLEGAL_STEP].copy()
        block.terms = dict(zip(rw.DECISION_TERMS, terms, strict=True))
        return total

    def _checkpoint_terms(self, block: Block, active: np.ndarray) -> np.ndarray:
        """Terms scored on passing a checkpoint, and the reverse penalty."""
        out, block.passed, block.since = rw.checkpoint_terms(
            self.config.weights, self.config.agent == "mcts-rl", self.horizon, block.world, block.tables,
            block.plan_lane, block.plan_speed, active, block.passed, block.since, block.reach_count, block.first_time,
        )  # fmt: skip
        return out
