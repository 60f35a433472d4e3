"""``karting train``: PPO self-play training of an RL agent from the command line, its options also read from a
TOML file (``--config``)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer
from typer.core import TyperCommand

from karting.output import JsonOption, console, print_json


def _training_tracks(names: str | None) -> tuple[str, ...] | None:
    """``--tracks`` of ``karting train`` as names, each a built-in track (``BadParameter`` naming one that is not)."""
    if names is None:
        return None
    from sim_core.track_io import get_track

    chosen = tuple(name.strip() for name in names.split(",") if name.strip())
    if not chosen:
        raise typer.BadParameter("no track named", param_hint="--tracks")
    for name in chosen:
        try:
            get_track(name)
        except KeyError as exc:
            raise typer.BadParameter(str(exc.args[0]), param_hint="--tracks") from None
    return chosen


# options of ``karting train`` that a --config file does not set: the agent names the table to read, and --json
# is how this run prints, not how it trains
NOT_IN_TRAIN_CONFIG = ("agent", "config", "as_json")


class TrainCommand(TyperCommand):
    """``karting train``: every option not given on the command line is taken from ``--config`` when the file
    sets it (:func:`controllers.rl.config.read_train_options`), checked as the flag's value would be."""

    # ctx: the click context typer makes (its own vendored click in recent typer, the click package in older)
    def invoke(self, ctx: Any) -> Any:
        """Fill the options from the file, then train."""
        if ctx.params.get("config") is not None:
            _apply_train_config(ctx, Path(ctx.params["config"]))
        return super().invoke(ctx)


def _apply_train_config(ctx: Any, path: Path) -> None:
    """Set ``ctx.params`` from the TOML file at ``path`` where the command line left an option at its default."""
    from controllers.rl.config import read_train_options

    params = {p.name: p for p in ctx.command.params if p.name and p.name not in NOT_IN_TRAIN_CONFIG}
    try:
        options = read_train_options(path, str(ctx.params.get("agent")), params)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--config") from None
    for name, value in options.items():
        source = ctx.get_parameter_source(name)
        if source is not None and source.name != "DEFAULT":  # given on the command line: the flag wins
            continue
        flag = bool(getattr(params[name], "is_flag", False))
        if isinstance(value, bool) != flag:  # TOML's true / false only for on/off flags, never for a number
            wanted = "true or false" if flag else "a value, not true / false"
            raise typer.BadParameter(f"{path}: {name}: expected {wanted}, got {value!r}", param_hint="--config")
        try:
            ctx.params[name] = params[name].process_value(ctx, value)
        except typer.BadParameter as exc:
            raise typer.BadParameter(f"{path}: {name}: {exc.message}", param_hint="--config") from None


def train(
    agent: Annotated[str, typer.Argument(help="mcts-rl, fixed-rl or e2e")],
    config: Annotated[
        Path | None,
        typer.Option(
            help="read the options from this TOML file (keys: the options' names; a table named after an agent: "
            "that agent's own); a flag given here overrides the file. Example: controllers/rl/configs/shipped.toml"
        ),
    ] = None,
    out: Annotated[Path | None, typer.Option(help="output folder (default runs/rl/AGENT)")] = None,
    steps: Annotated[int, typer.Option(help="environment steps in all (the paper: 8M)")] = 8_000_000,
    races: Annotated[int, typer.Option(help="races simulated together, one learning kart each")] = 128,
    seed: Annotated[int, typer.Option()] = 0,
    checkpoint_steps: Annotated[int, typer.Option(help="a checkpoint every this many steps")] = 500_000,
    resume: Annotated[bool, typer.Option(help="continue from the model in OUT")] = False,
    threads: Annotated[int, typer.Option(help="torch threads (1 is fastest on a shared 2-core machine)")] = 1,
    normalise_reward: Annotated[bool, typer.Option(help="running reward normalisation (not in the spec)")] = False,
    wall_hit_penalty: Annotated[float | None, typer.Option(help="per-ray wall penalty (spec: 50)")] = None,
    near_wall_spawns: Annotated[float | None, typer.Option(help="near-wall spawn probability (spec: 0.3)")] = None,
    log_std_init: Annotated[float, typer.Option(help="initial log std of the Gaussian actions (SB3: 0)")] = 0.0,
    ent_coef: Annotated[float, typer.Option(help="entropy bonus (spec: 5e-3)")] = 5e-3,
    gamma: Annotated[float, typer.Option(help="discount per decision (spec: 0.99)")] = 0.99,
    near_wall_heading_deg: Annotated[
        float, typer.Option(help="near-wall spawns turned toward the wall by up to this (spec: 0)")
    ] = 0.0,
    solo_spawns: Annotated[
        float,
        typer.Option(
            min=0.0,
            max=1.0,
            help="probability a training race has no opponent racing (finished phantoms; ours, spec: 0)",
        ),
    ] = 0.0,
    mcts_speed_sigma: Annotated[
        float,
        typer.Option(
            min=0.0,
            max=5.0,
            help="MCTS-RL's random training plans ask for 15 - |N(0, sigma)| m/s at each waypoint (spec: 1.5; "
            "0: top speed everywhere, what mcts-rl's planner sends when no kart is ahead)",
        ),
    ] = 1.5,
    karts: Annotated[
        int,
        typer.Option(
            min=2,
            max=8,
            help="karts per training race (the learner and its self-play opponents; the paper: 2). A shipped "
            "agent fine-tuned in larger races is widened: the added opponents' inputs start at zero weight",
        ),
    ] = 2,
    fine_tune_from: Annotated[
        Path | None,
        typer.Option(
            help="start from this trained folder, or a shipped agent's (its actor, fresh critic); fresh step count"
        ),
    ] = None,
    reward_weight: Annotated[
        list[str] | None,
        typer.Option(
            help="override one reward weight, NAME=VALUE (a RewardWeights field, e.g. target_lane=0); repeatable"
        ),
    ] = None,
    tracks: Annotated[
        str | None,
        typer.Option(
            help="training tracks, comma separated: built-in names, NAME-reversed for the other way (default: the "
            "training set of controllers/rl/config.py::TRAINING_TRACKS)"
        ),
    ] = None,
    as_json: JsonOption = False,
) -> None:
    """Train an RL agent by PPO self-play on the training ovals (progress bar, checkpoints, log and curves)."""
    from dataclasses import replace

    from controllers.rl.config import PPOConfig, agent_kind, override_weights
    from controllers.rl.envs import make_config
    from controllers.rl.train import train as run_training

    kind = agent_kind(agent)
    folder = out or Path("runs") / "rl" / kind
    ppo = PPOConfig(
        total_steps=steps,
        n_races=races,
        seed=seed,
        checkpoint_steps=checkpoint_steps,
        torch_threads=threads,
        normalise_reward=normalise_reward,
        log_std_init=log_std_init,
        ent_coef=ent_coef,
        gamma=gamma,
    )
    env = make_config(kind, tracks=_training_tracks(tracks))
    if wall_hit_penalty is not None:
        env = replace(env, weights=replace(env.weights, wall_hit=wall_hit_penalty))
    if reward_weight:
        try:
            env = replace(env, weights=override_weights(env.weights, reward_weight))
        except ValueError as exc:
            raise typer.BadParameter(str(exc), param_hint="--reward-weight") from exc
    if near_wall_spawns is not None:
        env = replace(env, near_wall_probability=near_wall_spawns)
    env = replace(
        env,
        near_wall_heading=math.radians(near_wall_heading_deg),
        solo_probability=solo_spawns,
        mcts_speed_sigma=mcts_speed_sigma,
        n_karts=karts,
    )
    result = run_training(env, ppo, folder, resume=resume, progress_bar=not as_json, fine_tune_from=fine_tune_from)
    if as_json:
        print_json(
            {
                "agent": kind,
                "timesteps": result.timesteps,
                "wall_s": round(result.wall_s, 3),
                "env_steps_per_s": round(result.env_steps_per_s, 1),
                "out": str(result.out),
            }
        )
        return
    console.print(
        f"{kind}: {result.timesteps} steps in {result.wall_s:.0f} s ({result.env_steps_per_s:,.0f} env steps/s); "
        f"model, statistics, log and curves in {result.out}"
    )
