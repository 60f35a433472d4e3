"""``karting reproduce``: regenerate the project's published results from scratch (:mod:`arena.reproduce`)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from karting.output import console, error
from karting.tournament_cli import DbOption, open_tournaments

if TYPE_CHECKING:
    from arena.publish import Tournament
    from arena.tournament import TournamentSpec
    from server.tournament_db import TournamentDatabase

app = typer.Typer(help="Regenerate the published results (docs/results/) from scratch.", no_args_is_help=True)


@app.command()
def paper(
    races_paper: Annotated[int, typer.Option(min=1, help="races per pair and track under paper conditions")] = 50,
    races_varied: Annotated[int, typer.Option(min=1, help="races per pair and track under varied conditions")] = 100,
    seed: Annotated[int, typer.Option(help="the tournaments' seed")] = 0,
    workers: Annotated[int | None, typer.Option(min=1, help="worker processes (default: one per CPU)")] = None,
    out: Annotated[Path, typer.Option(help="the results folder")] = Path("docs/results"),
    readme: Annotated[Path, typer.Option(help="the README whose results block gets the findings")] = Path("README.md"),
    db: DbOption = "runs/reproduce.db",
) -> None:
    """Run the paper's round robin (five agents, oval and complex) under paper and varied conditions, publish
    each into OUT/CONDITIONS/ and the findings beside the paper's into OUT/README.md and the README's results
    block. Interrupted, it resumes where it stopped (the races are stored in DB)."""
    from arena.reproduce import reproduction_of, reproduction_spec, tournament_id, write_findings

    Path(db).parent.mkdir(parents=True, exist_ok=True)
    store = open_tournaments(db)
    reproductions = []
    for conditions, races in (("paper", races_paper), ("varied", races_varied)):
        spec = reproduction_spec(conditions, races, seed)
        tid = tournament_id(conditions, races, seed)
        tournament = _run_and_publish(store, tid, spec, workers, out / conditions)
        reproductions.append(reproduction_of(conditions, tournament))
    write_findings(reproductions, out, readme)
    console.print(f"wrote {out}/ and the results block of {readme}")


@app.command()
def teams(
    races: Annotated[
        int | None, typer.Option(min=2, help="races per pair and track, even: mirrored pairs (default 20)")
    ] = None,
    seed: Annotated[int, typer.Option(help="the tournament's seed")] = 0,
    workers: Annotated[int | None, typer.Option(min=1, help="worker processes (default: one per CPU)")] = None,
    out: Annotated[Path, typer.Option(help="the team results folder")] = Path("docs/results/teams"),
    original_logs: Annotated[
        Path | None, typer.Option(help="the original's team logs, for its figures beside ours")
    ] = Path("../shared/spec/original_logs_teams"),
    db: DbOption = "runs/reproduce.db",
) -> None:
    """Run the five agents as 2v2 teams (oval and complex, varied conditions, a one-row grid in mirrored pairs of
    races), publish the tournament into OUT/tournament/ and the team figures beside the original's into
    OUT/README.md. Interrupted, it resumes where it stopped."""
    from arena.reproduce_teams import (
        DEFAULT_TEAM_RACES,
        TOURNAMENT_FOLDER,
        team_findings,
        team_spec,
        team_tournament_id,
    )

    races = races or DEFAULT_TEAM_RACES
    try:
        spec = team_spec(races, seed)
    except ValueError as exc:
        error(str(exc))
        raise typer.Exit(2) from None
    Path(db).parent.mkdir(parents=True, exist_ok=True)
    store = open_tournaments(db)
    tid = team_tournament_id(races, seed)
    tournament = _run_and_publish(store, tid, spec, workers, out / TOURNAMENT_FOLDER)
    (out / "README.md").write_text(team_findings(tournament, original_logs))
    console.print(f"wrote {out}/")


@app.command()
def field(
    races: Annotated[int, typer.Option(min=1, help="races per track, even (reversed pairs)")] = 40,
    seed: Annotated[int, typer.Option(help="the study's seed")] = 0,
    workers: Annotated[int | None, typer.Option(min=1, help="worker processes (default: one per CPU)")] = None,
    out: Annotated[Path, typer.Option(help="the field results folder")] = Path("docs/results/field"),
    agents: Annotated[str | None, typer.Option(help="agents, comma separated (default: the paper's five)")] = None,
    baseline: Annotated[
        Path | None,
        typer.Option(help="a study of the same schedule (its folder): each agent's collisions paired against it"),
    ] = None,
) -> None:
    """Race the five agents (or AGENTS) in 8-kart free-for-all fields (oval, complex, brands-hatch; varied
    conditions, each kart finishing after the same distance from its slot) and write each agent's finish rate,
    safety per kart-race and rating into OUT/ (README.md, field.json, manifest); with BASELINE, each agent's
    collisions race by race against the agent in its slots there."""
    from arena.field_compare import field_races
    from arena.field_places import FaultPlace
    from arena.reproduce import PAPER_AGENTS
    from arena.reproduce_field import field_spec, run_field, write_field

    try:
        spec = field_spec(races, seed, tuple(agents.split(",")) if agents else PAPER_AGENTS)
        if baseline is not None:
            field_races(baseline)  # readable before hours of racing
    except (KeyError, ValueError, OSError) as exc:
        error(str(exc).strip("'\""))
        raise typer.Exit(2) from None
    console.print(f"field: {spec.total} races of {spec.field_size} karts")
    started = time.perf_counter()
    places: list[FaultPlace] = []
    done = run_field(spec, workers, on_race=lambda n, total: console.print(f"{n}/{total}", end="\r"), places=places)
    wall = time.perf_counter() - started
    try:
        write_field(out, spec, done, wall, baseline, places)
    except ValueError as exc:  # a baseline of another schedule: the study is still written, without it
        error(f"{exc}; written without the baseline")
        write_field(out, spec, done, wall, places=places)
    console.print(f"wrote {out}/ ({wall / 60:.1f} min)")


def _run_and_publish(
    store: TournamentDatabase, tid: str, spec: TournamentSpec, workers: int | None, folder: Path
) -> Tournament:
    """Run (or resume) tournament ``tid`` of ``spec`` in ``store`` and publish it into ``folder``."""
    from arena.publish import PublishError, publish
    from arena.tournament import run_tournament
    from server.tournament_db import TournamentStatus

    stored = store.create(tid, spec)
    console.print(f"{tid}: {spec.total} races ({stored.done} stored already)")
    started = time.perf_counter()
    run_tournament(spec, store, tid, backend="process", workers=workers, record=False)
    store.set_status(tid, TournamentStatus.FINISHED)
    console.print(f"{tid}: done in {time.perf_counter() - started:.0f} s")
    tournament = store.publishable(tid)
    assert tournament is not None
    try:
        publish(tournament, folder, None)
    except PublishError as exc:
        error(f"cannot publish {tid}:\n{exc}")
        raise typer.Exit(2) from None
    return tournament
