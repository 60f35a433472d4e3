"""The ``karting`` command line: list and import tracks, run headless races and tournaments, serve races live.

Each command imports the layers it composes when it runs: ``karting tracks`` needs only :mod:`sim_core`, so it
does not pay for loading the controllers (numba kernels) or the server (FastAPI, SQLAlchemy, viser).

Karts are numbered from 1 wherever a person reads (``kart 1``); ``--json`` output uses the API's shapes, where
``index`` is the kart's grid slot from 0 (kart number = index + 1). "at fault" counts collisions the referee
blamed on a kart; a controller's own errors and missed deadlines are "controller faults" (the server's only).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, cast

import typer

from karting.output import JsonOption, add_row, console, error, print_json, table
from karting.reproduce_cli import app as reproduce_app
from karting.scenarios_cli import app as scenarios_app
from karting.tournament_cli import app as tournament_app
from karting.train_cli import TrainCommand, train
from server.limits import MAX_KARTS, MIN_KARTS
from sim_core.track_io import TrackFormatError, builtin_track_names, get_track, import_centreline_csv, save_track

if TYPE_CHECKING:
    from controllers.race import RaceOutcome

app = typer.Typer(help="HeadToHead Karting: head-to-head autonomous kart racing with rules.", no_args_is_help=True)
app.add_typer(tournament_app, name="tournament")
app.add_typer(reproduce_app, name="reproduce")
app.add_typer(scenarios_app, name="scenarios")


@app.command()
def tracks(as_json: JsonOption = False) -> None:
    """List the built-in tracks (each also driven the other way as NAME-reversed)."""
    names = builtin_track_names()
    if as_json:
        print_json([get_track(n).summary() for n in [*names, *(f"{n}-reversed" for n in names)]])
        return
    shown = table(
        "Built-in tracks (each also as NAME-reversed)",
        ("name", "CPs", "length [m]", "laps", "L", "description"),
        keys=("name",),
        numeric=("CPs", "length [m]", "laps", "L"),
    )
    for name in names:
        s = get_track(name).summary()
        shown.add_row(
            name,
            str(s["checkpoints"]),
            str(s["length_m"]),
            str(s["laps"]),
            str(s["lane_change_limit"]),
            str(s["description"]),
        )
    console.print(shown)
    console.print("CPs: checkpoints · L: lanes a kart may cross on one straight", style="dim")


@app.command("import-track")
def import_track(
    csv_path: Annotated[Path, typer.Argument(help="centre line CSV: x_m,y_m,w_tr_right_m,w_tr_left_m")],
    out: Annotated[Path, typer.Option(help="where to write the track JSON")],
    scale: Annotated[float, typer.Option(help="multiply coordinates and widths by this")] = 1.0,
    width_scale: Annotated[
        float | None, typer.Option(help="multiply the widths by this instead (a kart-sized circuit wider)")
    ] = None,
    name: Annotated[str | None, typer.Option(help="track name (default: file stem)")] = None,
    laps: Annotated[int, typer.Option(min=1)] = 3,
    lane_change_limit: Annotated[int, typer.Option(min=0)] = 4,
    as_json: JsonOption = False,
) -> None:
    """Import a racetrack-database CSV centre line as a track file."""
    try:
        track = import_centreline_csv(
            csv_path, name=name, scale=scale, width_scale=width_scale, laps=laps, lane_change_limit=lane_change_limit
        )
    except (TrackFormatError, ValueError) as exc:
        error(str(exc))
        raise typer.Exit(2) from None
    save_track(track, out, include_centreline=True)
    s = track.summary()
    if as_json:
        print_json({"path": str(out), **s})
        return
    console.print(f"wrote {out}: {s['checkpoints']} checkpoints, {s['length_m']} m, {s['straights']} straights")


@app.command()
def solo(
    agents: Annotated[str, typer.Option(help="registered agents, comma separated")] = "mcts-rl,fixed-rl,e2e",
    tracks: Annotated[
        str, typer.Option(help="tracks, comma separated: built-in names or track JSON paths")
    ] = "oval,complex,brands-hatch",
    races: Annotated[int, typer.Option(min=1, help="races per agent and track (seeds SEED, SEED + 1, ...)")] = 1,
    seed: Annotated[int, typer.Option()] = 0,
    conditions: Annotated[str, typer.Option(help="race conditions: paper, varied, ...")] = "paper",
    workers: Annotated[int | None, typer.Option(min=1, help="worker processes (default: one per core)")] = None,
    publish: Annotated[
        Path | None, typer.Option(help="write README.md, solo.json and manifest.json into this folder")
    ] = None,
    as_json: JsonOption = False,
) -> None:
    """Race each agent alone on each track: its best lap, the mean of its laps after the first, and its wall hits
    (what a change to its driving must not worsen)."""
    from arena.solo import publish_solo, run_solo  # loaded on use (see the module docstring)
    from controllers.race import load_any_track
    from controllers.registry import validate_agent
    from sim_core.conditions import condition_set

    names = [n.strip() for n in agents.split(",") if n.strip()]
    track_names = [t.strip() for t in tracks.split(",") if t.strip()]
    try:
        for name in names:
            validate_agent(name)
        for track_name in track_names:
            load_any_track(track_name)
        condition_set(conditions)
        started = time.perf_counter()
        figures = run_solo(names, track_names, races, seed, conditions, workers)
    except (KeyError, ValueError) as exc:
        error(str(exc.args[0]) if isinstance(exc, KeyError) else str(exc))
        raise typer.Exit(2) from None
    if publish is not None:
        spec = {"tracks": track_names, "races": races, "seed": seed, "conditions": conditions}
        options = f"--agents {agents} --tracks {tracks} --races {races} --seed {seed} --conditions {conditions}"
        command = f"karting solo {options} --publish {publish}"
        publish_solo(publish, figures, spec, command, time.perf_counter() - started)
    if as_json:
        print_json({"solo": [f.to_json() for f in figures]})
        return
    shown = table(
        f"alone, {races} race(s) each, {conditions} conditions",
        ["agent", "track", "finished", "best\n[s]", "flying\n[s]", "walls\n/race"],
        keys=["agent", "track"],
        numeric=["finished", "best\n[s]", "flying\n[s]", "walls\n/race"],
    )
    for f in figures:
        best = "-" if f.best_lap is None else f"{f.best_lap:.2f}"
        mean = "-" if f.mean_flying_lap is None else f"{f.mean_flying_lap:.2f}"
        add_row(shown, f.agent, f.track, f"{f.finished}/{f.races}", best, mean, f"{f.wall_hits_per_race:.1f}")
    console.print(shown)
    console.print("flying: the mean of the laps after the standing start; walls: wall hits per race", style="dim")


@app.command()
def race(
    track: Annotated[str, typer.Option(help="built-in track name, or a path to a track JSON")] = "oval",
    karts: Annotated[
        str,
        typer.Option(
            help="comma-separated registered controllers, one per kart; NAME:KEY=VALUE sets a parameter, e.g. "
            "mcts-lqng:iterations=500 (a quarter of the search budget)"
        ),
    ] = "mcts-lqng,fixed-lqng",
    laps: Annotated[int | None, typer.Option(min=1, help="laps (default: the track's)")] = None,
    seed: Annotated[int, typer.Option(help="seed of the planners")] = 0,
    start_lanes: Annotated[str | None, typer.Option(help="comma-separated start lanes, e.g. 2,3")] = None,
    kart: Annotated[str, typer.Option(help="kart preset: paper or original")] = "paper",
    plan_latency: Annotated[float, typer.Option(min=0.0, help="[s] delay before a new plan applies")] = 0.1,
    conditions: Annotated[
        str, typer.Option(help="race conditions drawn from the seed: paper (the original's) or varied")
    ] = "paper",
    replay: Annotated[Path | None, typer.Option(help="write a JSON replay (poses, inputs, plans) here")] = None,
    teams: Annotated[
        str | None,
        typer.Option(
            help="comma-separated team names, one per kart (e.g. blue,red,blue,red): the planners play for "
            "their team and the result scores the teams"
        ),
    ] = None,
    as_json: JsonOption = False,
) -> None:
    """Run a headless race between registered controllers and print the referee's result (karts numbered from
    1; --json: the API's result object, with ``winner`` and per-kart results, as the last line; with --teams also
    ``teams``: the winning team and each team's points, as the original's team races scored them)."""
    from controllers.race import RaceSpec, run_race  # loaded on use (see the module docstring)
    from controllers.registry import controller_names, validate_agent

    names = tuple(n.strip() for n in karts.split(",") if n.strip())
    if not MIN_KARTS <= len(names) <= MAX_KARTS:
        error(f"give {MIN_KARTS}-{MAX_KARTS} of {controller_names()}, got {list(names)}")
        raise typer.Exit(2)
    for name in names:
        try:
            validate_agent(name)
        except KeyError:
            error(f"unknown controller in {name!r}; known: {controller_names()} (NAME or NAME:KEY=VALUE:...)")
            raise typer.Exit(2) from None
        except ValueError as exc:
            error(str(exc))
            raise typer.Exit(2) from None
    try:
        lanes = tuple(int(x) for x in start_lanes.split(",")) if start_lanes else None
        team_names = tuple(t.strip() for t in teams.split(",")) if teams else None
        spec = RaceSpec(track, names, laps, seed, lanes, kart, plan_latency, conditions=conditions, teams=team_names)
        outcome = run_race(spec, record=replay is not None)
    except (TrackFormatError, KeyError, ValueError) as exc:
        error(str(exc))
        raise typer.Exit(2) from None
    record = race_result_json(outcome)
    if spec.teams is not None:
        record["teams"] = team_scores(outcome)
    if replay is not None and outcome.replay is not None:
        outcome.replay.save(replay)
    if as_json:
        print_json(record)
        return
    _print_race(track, outcome.wall_seconds, record)
    if "teams" in record:
        scores = cast(dict[str, Any], record["teams"])
        points = ", ".join(f"{team} {value:g}" for team, value in scores["points"].items())
        console.print(f"teams: {scores['winner'] or 'nobody'} won; points {points}", markup=False)
    if replay is not None:
        console.print(f"replay written to {replay}")


def team_scores(outcome: RaceOutcome) -> dict[str, object]:
    """A team race's winning team and each team's points (:func:`arena.teams.team_result`)."""
    from arena.race import kart_figures
    from arena.records import RaceFigures
    from arena.teams import team_result

    spec = outcome.spec
    karts = sorted(outcome.result.karts, key=lambda k: k.kart)
    race = RaceFigures(spec.track, tuple(kart_figures(spec.controllers[k.kart], k) for k in karts), teams=spec.teams)
    result = team_result(race)
    return {"winner": result.winner, "points": dict(result.points), "tied": result.tied}


def race_result_json(outcome: RaceOutcome) -> dict[str, object]:
    """A headless race's result in the API's shape (``GET /api/races/{id}/result``, with its manifest) plus its
    wall time [s]."""
    from arena.manifest import race_manifest
    from controllers.race import load_any_track
    from server.limits import default_kart_name
    from server.race_config import KartEntry
    from server.results import DriverFaults, RaceSetup, race_record
    from server.status import RaceStatus
    from sim_core.world import grid_lanes

    spec, result = outcome.spec, outcome.result
    karts = [KartEntry(k, default_kart_name(name, k), name) for k, name in enumerate(spec.controllers)]
    setup = RaceSetup(spec.seed, spec.kart_preset, grid_lanes(len(karts), spec.start_lanes))
    status = RaceStatus.FINISHED if result.done else RaceStatus.STOPPED
    laps = spec.laps if spec.laps is not None else load_any_track(spec.track).laps
    faults = [DriverFaults()] * len(karts)
    manifest = race_manifest(spec)
    record = race_record(
        "headless", status, spec.track, laps, result, karts, faults, setup, outcome.lap_times, manifest=manifest
    )
    drawn = outcome.conditions.to_json() if outcome.conditions is not None else None
    return {**record.to_json(), "conditions": drawn, "wall_seconds": round(outcome.wall_seconds, 3)}


def _print_race(track: str, wall_seconds: float, record: dict[str, Any]) -> None:
    """The result as a table, karts numbered from 1, then the winner."""
    columns = (
        "kart",
        "name",
        "pos",
        "time\n[s]",
        "laps",
        "at\nfault",
        "illegal\nLC",
        "safety",
        "walls",
        "Δr\n[m]",
        "Δv\n[m/s]",
    )
    shown = table(
        f"{track}: {record['duration']:.2f} s simulated in {wall_seconds:.2f} s",
        columns,
        keys=("name",),
        numeric=tuple(c for c in columns if c != "name"),
    )
    for k in sorted(record["karts"], key=lambda k: k["position"]):
        add_row(
            shown,
            str(k["index"] + 1),
            k["name"],
            str(k["position"]),
            f"{k['finish_time']:.3f}" if k["finish_time"] is not None else "DNF",
            str(k["laps"]),
            str(k["collisions_at_fault"]),
            str(k["illegal_lane_changes"]),
            str(k["safety_score"]),
            str(k["wall_hits"]),
            "-" if k["delta_r"] is None else f"{k['delta_r']:.2f}",
            "-" if k["delta_v"] is None else f"{k['delta_v']:.2f}",
        )
    console.print(shown)
    console.print(
        "at fault: collisions at fault · illegal LC: illegal lane changes · safety = at fault + illegal LC "
        "(lower is safer) · Δr, Δv: mean distance from the planned lane and speed at checkpoints",
        style="dim",
    )
    for k in record["karts"]:
        laps = ", ".join(f"{t:.3f}" for t in k["lap_times"]) or "none"
        console.print(f"kart {k['index'] + 1} lap times \\[s]: {laps}", soft_wrap=True)
    winner = record["winner"]
    if winner is None:
        console.print("winner: nobody (no finisher)")
    else:
        console.print(f"winner: kart {winner + 1} ({record['karts'][winner]['name']})")


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


app.command(cls=TrainCommand)(train)

if __name__ == "__main__":
    app()
