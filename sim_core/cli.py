"""The ``karting`` command line: list and import tracks, run headless races."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from sim_core import state as st
from sim_core.params import SimParams, kart_preset
from sim_core.track_io import TrackFormatError, builtin_track_names, get_track, import_centreline_csv, save_track
from sim_core.world import World

app = typer.Typer(help="HeadToHead Karting: head-to-head autonomous kart racing with rules.", no_args_is_help=True)
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
    karts: Annotated[int, typer.Option(min=1, max=8, help="number of karts")] = 2,
    laps: Annotated[int | None, typer.Option(min=1, help="laps (default: the track's)")] = None,
    start_lanes: Annotated[str | None, typer.Option(help="comma-separated start lanes, e.g. 2,3")] = None,
    kart: Annotated[str, typer.Option(help="kart preset: paper or original")] = "paper",
) -> None:
    """Run a headless race of lane-following karts and print the referee's result.

    Until the controller registry exists every kart is the pure-pursuit lane follower, kart i following
    its start lane.
    """
    from controllers.lane_follower import LaneFollower  # controllers compose sim_core, not the reverse

    try:
        the_track = _load(track)
        params = SimParams(kart=kart_preset(kart))
        lanes = [int(x) for x in start_lanes.split(",")] if start_lanes else None
        world = World(the_track, 1, karts, params, laps=laps)
        world.reset(start_lanes=lanes)
    except (TrackFormatError, KeyError, ValueError) as exc:
        console.print(f"[red]error:[/red] {exc}")
        raise typer.Exit(2) from None
    follower = LaneFollower(the_track, params.kart)
    lateral = np.array([[world.fstate[0, k, st.F_D] for k in range(karts)]])
    t0 = time.perf_counter()
    while not world.done[0]:
        actions = follower.act(
            world.positions,
            world.headings,
            world.speeds,
            world.fstate[:, :, st.F_S],
            world.fstate[:, :, st.F_WEAR],
            lateral,
        )
        world.step(actions)
    wall = time.perf_counter() - t0
    result = world.result(0)
    table = Table(title=f"{the_track.name}, {world.laps} laps: {result.duration:.2f} s simulated in {wall:.2f} s")
    for col in (
        "kart",
        "pos",
        "time [s]",
        "laps",
        "faults",
        "illegal LC",
        "safety",
        "walls",
        "buffer",
        "Δr [m]",
        "Δv [m/s]",
    ):
        table.add_column(col, justify="right")
    for kr in sorted(result.karts, key=lambda r: r.position):
        table.add_row(
            str(kr.kart),
            str(kr.position),
            f"{kr.finish_time:.2f}" if kr.finish_time is not None else "DNF",
            str(kr.laps_completed),
            str(kr.collisions_at_fault),
            str(kr.illegal_lane_changes),
            str(kr.safety_score),
            str(kr.wall_hits),
            str(kr.buffer_violations),
            "-" if kr.delta_r is None else f"{kr.delta_r:.2f}",
            "-" if kr.delta_v is None else f"{kr.delta_v:.2f}",
        )
    console.print(table)
    console.print(f"winner: {'kart ' + str(result.winner) if result.winner is not None else 'nobody (no finisher)'}")


def _load(track: str):  # type: ignore[no-untyped-def]
    from sim_core.track_io import load_track

    if track.endswith(".json") or "/" in track:
        return load_track(track)
    return get_track(track)


if __name__ == "__main__":
    app()
