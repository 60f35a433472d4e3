"""The RL environments: train your own agent against ours through Gymnasium or PettingZoo.

From the repo root::

    .venv/bin/python examples/05_rl_env.py                      # E2E observations, a few seconds
    .venv/bin/python examples/05_rl_env.py --agent fixed-rl --decisions 200

``import controllers.rl.envs`` registers the Gymnasium ids ``karting/KartRace-v0`` and ``karting/KartRace-
{MCTSRL,FixedRL,E2E}-v0``: one learning kart (kart 0) against a random opponent on the training ovals, an
observation of 4 stacked frames (own state, the opponent, the next 5 targets, the 9 rays), an action
``[steer, pedal]`` in [-1, 1] held for 2 physics steps (25 Hz), the appendix's reward. ``gym.make_vec`` gives
the batched vector env (every race in one compiled World call, same-step autoreset). The PettingZoo
``parallel_env`` has one agent per kart. Here: a random policy in each, then the shipped E2E policy
(:mod:`controllers.rl.policy`, plain numpy) driving the Gymnasium env, and the rewards they collect.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import controllers.rl.envs as envs
from controllers.rl.policy import load_policy, weights_folder

TAGS = {"mcts-rl": "MCTSRL", "fixed-rl": "FixedRL", "e2e": "E2E"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--agent", choices=sorted(TAGS), default="e2e")
    parser.add_argument("--decisions", type=int, default=100, help="decisions per environment")
    args = parser.parse_args()

    # Gymnasium: one race, a random learner
    env = gym.make(f"karting/KartRace-{TAGS[args.agent]}-v0", tracks=("train-oval-small",))
    obs, _ = env.reset(seed=0)
    print(f"gymnasium: observation {obs.shape}, action space {env.action_space}")
    total = sum(float(env.step(env.action_space.sample())[1]) for _ in range(args.decisions))
    print(f"gymnasium: random policy, reward {total:.1f} over {args.decisions} decisions")

    # the shipped policy of this agent driving the same env (numpy only; torch is for training)
    policy = load_policy(weights_folder(args.agent))
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    total = 0.0
    for _ in range(args.decisions):
        obs, reward, terminated, truncated, _ = env.step(policy.act(obs, rng))
        total += float(reward)
        if terminated or truncated:
            obs, _ = env.reset()
    print(f"gymnasium: shipped {args.agent} policy, reward {total:.1f} over {args.decisions} decisions")
    env.close()

    # the vector env: 16 races stepped together
    venv = gym.make_vec(
        f"karting/KartRace-{TAGS[args.agent]}-v0",
        num_envs=16,
        vectorization_mode="vector_entry_point",
        tracks=("oval",),
    )
    venv.reset(seed=0)
    rewards = np.zeros(16)
    for _ in range(args.decisions):
        rewards += venv.step(venv.action_space.sample())[1]
    print(f"vector env: 16 races, mean reward {rewards.mean():.1f} per race")
    venv.close()

    # PettingZoo: every kart an agent
    par = envs.parallel_env(args.agent, tracks=("train-oval-small",))
    par.reset(seed=0)
    returns = dict.fromkeys(par.agents, 0.0)
    for _ in range(args.decisions):
        if not par.agents:
            break
        actions = {a: par.action_space(a).sample() for a in par.agents}
        _, rewards_, _, _, _ = par.step(actions)
        for a, r in rewards_.items():
            returns[a] += float(r)
    print("pettingzoo: " + ", ".join(f"{a} {r:.1f}" for a, r in returns.items()))


if __name__ == "__main__":
    main()
