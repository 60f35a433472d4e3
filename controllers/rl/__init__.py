"""Multi-agent RL for the paper's learned agents (MCTS-RL, Fixed-RL, E2E): environments, rewards, PPO self-play.

The environment modules (:mod:`.config`, :mod:`.observations`, :mod:`.actions`, :mod:`.rewards`, :mod:`.spawns`,
:mod:`.batch`, :mod:`.envs`) need numpy, gymnasium and pettingzoo only; torch and Stable-Baselines3 are
imported by :mod:`.selfplay` and :mod:`.train` alone (this package is the only place in the project that may).
"""
