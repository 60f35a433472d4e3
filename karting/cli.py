"""The ``karting`` command line: list and import tracks, run headless races and tournaments, serve races live.

Each command imports the layers it composes when it runs: ``karting tracks`` needs only :mod:`sim_core`, so it
does not pay for loading the controllers (numba kernels) or the server (FastAPI, SQLAlchemy, viser).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from karting.tournament_cli import app as tournament_app
from sim_core.track_io import TrackFormatError, builtin_track_names, get_track, import_centreline_csv, save_track

app = typer.Typer(help="HeadToHead Karting: head-to-head autonomous kart racing with rules.", no_args_is_help=True)
app.add_typer(tournament_app, name="tournament")
console = Console()


@app.command()
def tracks() -> None:
    """List the built-in tracks."""
    table = Table(title="Built-in tracks (each also as NAME-reversed)")
    for col in ("name", "checkpoints", "length [m]", "laps", "L", "straights", "description"):
        table.add_column(col)
    for name in builtin_track_names():
        s = get_track(name).summary()
        table.add_row(
            name,
            str(s["checkpoints"]),
            str(s["length_m"]),
            str(s["laps"]),
            str(s["lane_change_limit"]),
            str(s["straights"]),
            str(s["description"]),
        )
    console.print(table)


@app.command("import-track")
def import_track(
    csv_path: Annotated[Path, typer.Argument(help="centre line CSV: x_m,y_m,w_tr_right_m,w_tr_left_m")],
    out: Annotated[Path, typer.Option(help="where to write the track JSON")],
    scale: Annotated[float, typer.Option(help="multiply coordinates and widths by this")] = 1.0,
    name: Annotated[str | None, typer.Option(help="track name (default: file stem)")] = None,
    laps: Annotated[int, typer.Option(min=1)] = 3,
    lane_change_limit: Annotated[int, typer.Option(min=0)] = 4,
) -> None:
    """Import a racetrack-database CSV centre line as a track file."""
    try:
        track = import_centreline_csv(csv_path, name=name, scale=scale, laps=laps, lane_change_limit=lane_change_limit)
    except (TrackFormatError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    save_track(track, out, include_centreline=True)
    s = track.summary()
    console.print(f"wrote {out}: {s['checkpoints']} checkpoints, {s['length_m']} m, {s['straights']} straights")


@app.command()
def race(
    track: Annotated[str, typer.Option(help="built-in track name, or a path to a track JSON")] = "oval",
    karts: Annotated[
        str, typer.Option(help="comma-separated registered controllers, one per kart")
    ] = "mcts-lqng,fixed-lqng",
    laps: Annotated[int | None, typer.Option(min=1, help="laps (default: the track's)")] = None,
    seed: Annotated[int, typer.Option(help="seed of the planners")] = 0,
    start_lanes: Annotated[str | None, typer.Option(help="comma-separated start lanes, e.g. 2,3")] = None,
    kart: Annotated[str, typer.Option(help="kart preset: paper or original")] = "paper",
    plan_latency: Annotated[float, typer.Option(min=0.0, help="[s] delay before a new plan applies")] = 0.1,
    replay: Annotated[Path | None, typer.Option(help="write a JSON replay (poses, inputs, plans) here")] = None,
) -> None:
    """Run a headless race between registered controllers and print the referee's result."""
    from controllers.race import RaceSpec, run_race  # loaded on use (see the module docstring)
    from controllers.registry import controller_names

    names = tuple(n.strip() for n in karts.split(",") if n.strip())
    unknown = [n for n in names if n not in controller_names()]
    if unknown or not 1 <= len(names) <= 8:
        console.print(f"[red]error:[/red] give 1-8 of {controller_names()}, got {list(names)}")
        raise typer.Exit(2)
    try:
        lanes = tuple(int(x) for x in start_lanes.split(",")) if start_lanes else None
        spec = RaceSpec(track, names, laps, seed, lanes, kart, plan_latency)
        outcome = run_race(spec, record=replay is not None)
    except (TrackFormatError, KeyError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    result = outcome.result
    table = Table(title=f"{track}: {result.duration:.2f} s simulated in {outcome.wall_seconds:.2f} s")
    for col in (
        "kart",
        "driver",
        "pos",
        "time [s]",
        "laps",
        "faults",
        "illegal LC",
        "safety",
        "walls",
        "Δr [m]",
        "Δv [m/s]",
    ):
        table.add_column(col, justify="right")
    for kr in sorted(result.karts, key=lambda r: r.position):
        table.add_row(
            str(kr.kart),
            names[kr.kart],
            str(kr.position),
            f"{kr.finish_time:.2f}" if kr.finish_time is not None else "DNF",
            str(kr.laps_completed),
            str(kr.collisions_at_fault),
            str(kr.illegal_lane_changes),
            str(kr.safety_score),
            str(kr.wall_hits),
            "-" if kr.delta_r is None else f"{kr.delta_r:.2f}",
            "-" if kr.delta_v is None else f"{kr.delta_v:.2f}",
        )
    console.print(table)
    winner = f"kart {result.winner} ({names[result.winner]})" if result.winner is not None else "nobody (no finisher)"
    console.print(f"winner: {winner}")
    if replay is not None and outcome.replay is not None:
        outcome.replay.save(replay)
        console.print(f"replay written to {replay}")


@app.command()
def serve(
    host: Annotated[str | None, typer.Option(help="interface to listen on (default 127.0.0.1, KARTING_HOST)")] = None,
    port: Annotated[int | None, typer.Option(min=0, max=65535, help="port (default 8000, KARTING_PORT)")] = None,
    db: Annotated[
        str | None, typer.Option(help="SQLite file or database URL (default ./karting.db, KARTING_DATABASE_URL)")
    ] = None,
    no_viewer: Annotated[bool, typer.Option("--no-viewer", help="run without the 3D view")] = False,
) -> None:
    """Run the race server (REST API, websockets, live 3D view) until Ctrl-C."""
    from server.app import serve as run_server  # loaded on use (see the module docstring)
    from server.settings import Settings

    overrides: dict[str, object] = {}
    if host is not None:
        overrides["host"] = host
    if port is not None:
        overrides["port"] = port
    if db is not None:
        overrides["database_url"] = db if "://" in db else f"sqlite:///{db}"
    if no_viewer:
        overrides["viewer_enabled"] = False
    run_server(Settings(**overrides))  # type: ignore[arg-type]


@app.command()
def train(
    agent: Annotated[str, typer.Argument(help="mcts-rl, fixed-rl or e2e")],
    out: Annotated[Path | None, typer.Option(help="output folder (default results/rl/AGENT)")] = None,
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
    fine_tune_from: Annotated[
        Path | None, typer.Option(help="start from this trained folder (fresh step count and schedule)")
    ] = None,
) -> None:
    """Train an RL agent by PPO self-play on the training ovals (progress bar, checkpoints, log and curves)."""
    from dataclasses import replace

    from controllers.rl.config import PPOConfig, agent_kind
    from controllers.rl.envs import make_config
    from controllers.rl.train import train as run_training

    kind = agent_kind(agent)
    folder = out or Path("results") / "rl" / kind
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
    env = make_config(kind)
    if wall_hit_penalty is not None:
        env = replace(env, weights=replace(env.weights, wall_hit=wall_hit_penalty))
    if near_wall_spawns is not None:
        env = replace(env, near_wall_probability=near_wall_spawns)
    env = replace(env, near_wall_heading=math.radians(near_wall_heading_deg))
    result = run_training(env, ppo, folder, resume=resume, progress_bar=True, fine_tune_from=fine_tune_from)
    console.print(
        f"{kind}: {result.timesteps} steps in {result.wall_s:.0f} s ({result.env_steps_per_s:,.0f} env steps/s); "
        f"model, statistics, log and curves in {result.out}"
    )


if __name__ == "__main__":
    app()
