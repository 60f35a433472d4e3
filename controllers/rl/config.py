"""Settings of the RL agents: which agent, the reward weights of the appendix, the environment and PPO defaults.

Figures come from ``../shared/spec/original_implementation.md`` section 6: the reward weights of the
``CompeteAgents-Oval`` training environment (the spec's best guess for the final training scene), decisions
every 2 physics steps (25 Hz), observations stacked over 4 decisions, a horizon of 5 checkpoints, 1500-step
(30 s) one-lap episodes, and the ML-Agents PPO / self-play configuration.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal

AgentKind = Literal["mcts-rl", "fixed-rl", "e2e"]
AGENT_KINDS: tuple[AgentKind, ...] = ("mcts-rl", "fixed-rl", "e2e")
TRAINING_TRACKS: tuple[str, ...] = (
    "train-oval-small",
    "train-oval-large",
    "train-oval-small-reversed",
    "train-oval-large-reversed",
    # not in the original's training set: without a corner under 10 m the agents ran wide into complex's
    # 1-5 m hairpins and stuck against the wall
    "train-hairpins",
    "train-hairpins-reversed",
)

DECISION_STEPS = 2  # physics steps per decision (the action is held in between): 25 Hz
STACK = 4  # decisions stacked in one observation
HORIZON = 5  # upcoming targets observed (sectionHorizon)
EPISODE_STEPS = 1500  # [physics steps] = 30 s, the original's maxEpisodeSteps
SPEED_SCALE = 15.0  # [m/s] LocalSpeed = v / 15 in the original's observations
# the original's per-ray wall thresholds [m], in SensorParams.angles_deg order (0, +30, +45, +60, +90, -30, ...)
WALL_THRESHOLDS: tuple[float, ...] = (0.8, 0.9, 1.0, 0.8, 0.6, 0.9, 1.0, 0.8, 0.6)
OPPONENT_THRESHOLD = 1.5  # [m] on every ray
FRONT_RAYS: tuple[int, ...] = (0, 1, 5)  # Theta of the appendix: the rays at 0 and +-30 deg
POSITION_FACTORS: tuple[float, ...] = (1.0, 0.75, 0.6, 0.4)  # k for the 1st..4th kart to reach a checkpoint
LANE_DEADZONE = 1.3  # [m] D_lane = 1 within this distance of the target lane point
SPEED_BIN = 1.0  # [m/s] velocity bin of the plans; D_vel = 1 within half of it


def agent_kind(name: str) -> AgentKind:
    """Check an agent name (``mcts-rl``, ``fixed-rl`` or ``e2e``)."""
    for kind in AGENT_KINDS:
        if kind == name:
            return kind
    raise ValueError(f"unknown RL agent {name!r}; known: {list(AGENT_KINDS)}")


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the reward terms (the original's ENV field names in comments); positive numbers, the term
    functions in :mod:`controllers.rl.rewards` apply the sign. Defaults: the ``CompeteAgents-Oval`` training set."""

    speed: float = 1.0  # SpeedReward, R_speed
    direction: float = 0.008  # TowardsCheckpointReward, R_direction
    acceleration: float = 0.002  # AccelerationReward (in the code, not the appendix)
    not_at_goal: float = 0.001  # NotAtGoalPenalty (in the code, not the appendix)
    swerve: float = 15.0  # SwervingPenalty, R_swerve
    wall_hit: float = 50.0  # WallHitPenalty, R_wall-hit (per ray)
    player_hit: float = 4.5  # OpponentHitPenalty, omega_1 of R_player-hit (per ray)
    # omega_2 of R_player-hit: the extra for a front ray (at fault). The spec lists no separate figure; the
    # original charged OpponentHitPenalty per ray, so the extra defaults to the same weight [INF].
    player_hit_front: float = 4.5
    hit_by_player: float = 3.5  # HitByOpponentPenalty, to the kart another kart's ray found
    checkpoint_base: float = 2.0  # PassCheckpointBase, R_checkpoint base
    checkpoint_time: float = 20.0  # PassCheckpointTimeMultiplier, R_checkpoint time
    behind_opponent: float = 0.06  # BeingBehindOpponentCheckpointPenalty (per step behind the first kart)
    target_lane: float = 4.0  # PassCheckpointLaneReward, omega_1 of R_checkpoint target
    target_speed: float = 4.0  # PassCheckpointVelocityReward, omega_2 of R_checkpoint target (MCTS-RL only)
    reverse: float = 10.0  # ReversePenalty, R_checkpoint reverse


def reward_weights(kind: AgentKind) -> RewardWeights:
    """The per-agent weights: D_vel (the target-speed term) applies to MCTS mode only; Fixed-RL and E2E get its
    weight unscaled (D_vel = 1) on every checkpoint, as the original. E2E has no plan: its target lane is the
    checkpoint centre, so the lane term rewards passing near the centre line (the original's D_lane on the
    centre box)."""
    return RewardWeights()


def override_weights(weights: RewardWeights, assignments: list[str] | tuple[str, ...]) -> RewardWeights:
    """``weights`` with each ``NAME=VALUE`` of ``assignments`` applied (the training command's
    ``--reward-weight``); a ValueError names an unknown field or a value that is not a non-negative number."""
    known = [f.name for f in fields(RewardWeights)]
    changes: dict[str, float] = {}
    for item in assignments:
        name, sep, text = item.partition("=")
        name = name.strip().replace("-", "_")
        if not sep or name not in known:
            raise ValueError(f"expected NAME=VALUE with NAME one of {known}, got {item!r}")
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"{name}: {text!r} is not a number") from None
        if not math.isfinite(value) or value < 0:
            raise ValueError(f"{name}: weights are non-negative numbers (the terms apply the sign), got {text!r}")
        changes[name] = value
    return replace(weights, **changes)


@dataclass(frozen=True)
class EnvConfig:
    """Training environment: agent, tracks, karts per race, spawns (``ENV.ResetGame`` in Training mode)."""

    agent: AgentKind = "mcts-rl"
    tracks: tuple[str, ...] = TRAINING_TRACKS
    n_karts: int = 2
    episode_steps: int = EPISODE_STEPS
    kart_preset: str = "paper"
    head_to_head_probability: float = 6.0 / 9.0  # second kart within +-1 checkpoint, distinct lanes
    near_wall_probability: float = 0.3  # spawn 1 m from the wall
    # [rad] near-wall spawns turned toward the wall by up to this (0: along the track, as the original). Ours:
    # agents that stopped nose to the wall in complex's hairpins had never been there in training
    near_wall_heading: float = 0.0
    # probability that a race's other karts are absent (finished phantoms 30 m behind the learner, as the race-time
    # tracker shows a missing opponent). Ours: the original always trained with every kart racing, and a solo
    # race (or one after the opponent finished) was then outside what the policies had seen
    solo_probability: float = 0.0
    spawn_ahead: tuple[float, float] = (1.0, 4.0)  # [m] past the checkpoint
    max_behind_time: float = 1.0  # [s] random earlier crossing times of the kart behind
    mcts_speed_sigma: float = 1.5  # [m/s] MCTS random plans: 15 - |N(0, 1.5)|
    weights: RewardWeights = field(default_factory=RewardWeights)

    def with_agent(self, kind: AgentKind) -> EnvConfig:
        """The same environment for another agent (its reward weights too)."""
        return replace(self, agent=kind, weights=reward_weights(kind))


@dataclass(frozen=True)
class PPOConfig:
    """PPO and self-play settings (``kart_mg_trainer_config_new.yaml``)."""

    total_steps: int = 8_000_000
    n_races: int = 128  # races simulated together (one learning kart each)
    learning_rate: float = 2e-4  # linear decay to 0
    batch_size: int = 512
    buffer_size: int = 10240  # n_steps * n_races
    n_epochs: int = 3
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_range: float = 0.2
    ent_coef: float = 5e-3
    hidden: tuple[int, ...] = (128, 128, 128)
    window: int = 10  # frozen past policies kept
    play_against_latest: float = 0.5
    save_steps: int = 20_000  # a snapshot joins the pool this often
    swap_steps: int = 10_000  # the opponent changes this often
    checkpoint_steps: int = 500_000
    seed: int = 0
    # running reward normalisation (VecNormalize norm_reward). Off in the spec (ML-Agents had none). With the
    # appendix's 50-per-ray wall penalty the value loss reaches ~1e5; normalised it stays ~1e-2 (measured), but
    # on its own that did not get an agent driving
    normalise_reward: bool = False
    # initial log standard deviation of the Gaussian actions (SB3's default 0: std 1 over a [-1, 1] range). At
    # std 1 the steering noise alone slowed training rollouts to half the mean's speed and the std never fell
    # in 2M steps (measured on interim weights)
    log_std_init: float = 0.0
    # 1: on a 2-core machine shared with other work, two OpenMP threads waiting on each other made a 512-sample
    # gradient step of the 3x128 nets 40x slower (53 ms against 1.4 ms, measured)
    torch_threads: int = 1


def read_train_options(path: Path, agent: str, known: Collection[str]) -> dict[str, Any]:
    """The options of ``karting train AGENT`` in the TOML file at ``path``, by option name (``wall_hit_penalty``).

    Top-level keys apply to every agent; a table named after an agent (``[e2e]``) adds or replaces keys for that
    agent only. A key is an option's name with ``_`` or ``-`` (``wall-hit-penalty``), its value what the flag
    takes (``reward_weight`` a list of ``NAME=VALUE`` strings); paths are read from the working directory, as
    on the command line. A ValueError names the first problem: unreadable or not TOML, a key outside ``known``
    (named), a table named after no agent, a key given twice in one place.
    """
    try:
        data = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not TOML: {exc}") from None
    for name, value in data.items():
        if isinstance(value, dict) and name not in AGENT_KINDS:
            raise ValueError(
                f"{path}: unknown key {name!r} (a table is an agent's own options: one of {list(AGENT_KINDS)})"
            )
    shared = {key: value for key, value in data.items() if not isinstance(value, dict)}
    options = _named_options(path, "", shared, known)
    own = data.get(agent)
    if isinstance(own, dict):
        options.update(_named_options(path, f"[{agent}] ", own, known))
    return options


def _named_options(path: Path, where: str, entries: Mapping[str, Any], known: Collection[str]) -> dict[str, Any]:
    """``entries`` by option name (``-`` read as ``_``); a ValueError names an unknown or repeated key."""
    options: dict[str, Any] = {}
    for key, value in entries.items():
        name = key.replace("-", "_")
        if name not in known:
            raise ValueError(f"{path}: unknown key {where}{key!r}; the options are {sorted(known)}")
        if name in options:
            raise ValueError(f"{path}: {where}{key!r} is given twice (as - and as _)")
        options[name] = value
    return options
