"""Environment steps per second during PPO self-play training (``karting train``'s loop) on this machine.

Runs a short training of MCTS-RL (warm-up excluded: the first update pays for compiling the kernels) and prints
one JSON object last, with ``env_steps_per_s`` (learner decisions per second of wall time, the count that
Stable-Baselines3's ``total_timesteps`` and the paper's 8M steps use), the learning time split into rollouts
(``rollout_s``: races, actions, buffer) and PPO updates (``update_s``), and the process's CPU seconds
(``cpu_s``: on a machine shared with other work, CPU time well under ``total_s`` means the run waited for a
core), and ``update_bound_env_steps_per_s``: the steps over the update time alone, the rate the loop could reach
with an environment that cost nothing (PPO's epochs over the spec's network and buffer bound it). Run from the repo
root:
``.venv/bin/python benchmarks/training.py`` (``--help``: the steps, races and rollout buffer; the smoke test runs
it tiny).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from controllers.rl.config import PPOConfig
from controllers.rl.envs import make_config
from controllers.rl.train import train


def main() -> None:
    """Warm up, then time a training run."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=153_600)
    parser.add_argument("--races", type=int, default=128)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--warm-steps", type=int, default=10_240, help="the untimed first run's steps")
    parser.add_argument("--buffer", type=int, default=PPOConfig.buffer_size, help="steps per rollout, all races")
    parser.add_argument("--batch", type=int, default=PPOConfig.batch_size, help="samples per gradient step")
    args = parser.parse_args()
    env = make_config("mcts-rl")
    sizes = {"n_races": args.races, "torch_threads": args.threads, "buffer_size": args.buffer}
    sizes |= {"batch_size": args.batch}
    with tempfile.TemporaryDirectory() as tmp:
        warm = PPOConfig(total_steps=args.warm_steps, **sizes)
        train(env, warm, Path(tmp) / "warm")
        ppo = PPOConfig(total_steps=args.steps, **sizes)
        start, cpu = time.perf_counter(), time.process_time()
        result = train(env, ppo, Path(tmp) / "run")
        total, cpu = time.perf_counter() - start, time.process_time() - cpu
    print(
        json.dumps(
            {
                "benchmark": "training",
                "agent": "mcts-rl",
                "races": args.races,
                "torch_threads": args.threads,
                "steps": result.timesteps,
                "learn_s": round(result.wall_s, 2),
                "rollout_s": round(result.rollout_s, 2),
                "update_s": round(result.update_s, 2),
                "total_s": round(total, 2),
                "cpu_s": round(cpu, 2),
                "env_steps_per_s": round(result.env_steps_per_s),
                "update_bound_env_steps_per_s": round(result.timesteps / max(result.update_s, 1e-9)),
            }
        )
    )


if __name__ == "__main__":
    main()
