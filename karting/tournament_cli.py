"""``karting tournament``: run a round robin (resumable), print the statistics (of a stored tournament or of the
original implementation's logs), write a report, and publish a finished tournament as the project's results.

    karting tournament run --agents mcts-lqng,fixed-lqng --tracks oval,complex --races-per-pair 50 --id grid
    karting tournament stats --id grid --json
    karting tournament stats --original-logs ../shared/spec/original_logs --json
    karting tournament stats --original-logs ../shared/spec/original_logs_teams --teams
    karting tournament report grid --out runs/tournaments/grid
    karting tournament publish grid --out docs/results --readme README.md
"""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, cast

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from karting.output import JsonOption, add_row, console, error, print_json
from karting.output import table as make_table

if TYPE_CHECKING:
    from arena.stats import TournamentStats, TrackStats
    from server.tournament_db import TournamentDatabase

app = typer.Typer(help="Round-robin tournaments: run, statistics, reports.", no_args_is_help=True)

DbOption = Annotated[str, typer.Option(help="SQLite file or database URL (the server's: ./karting.db)")]


def _names(text: str) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip())


def open_tournaments(db: str) -> TournamentDatabase:
    """The tournament store in the database ``db`` (a SQLite file or a URL)."""
    from server.db import RaceDatabase
    from server.tournament_db import TournamentDatabase

    return TournamentDatabase(RaceDatabase(db if "://" in db else f"sqlite:///{db}"))


@app.command()
def run(
    agents: Annotated[
        str, typer.Option(help="registered controllers, comma separated; NAME:KEY=VALUE sets a parameter")
    ] = ("mcts-rl,e2e,fixed-rl,mcts-lqng,fixed-lqng"),
    tracks: Annotated[str, typer.Option(help="tracks, comma separated")] = "oval,complex",
    races_per_pair: Annotated[int, typer.Option(min=1, help="races per pair and track")] = 50,
    seed: Annotated[int, typer.Option(help="the tournament's seed (every race's seed derives from it)")] = 0,
    laps: Annotated[int | None, typer.Option(min=1, help="laps (default: each track's)")] = None,
    time_limit: Annotated[float | None, typer.Option(min=1.0, help="[s] race time limit (default: the rules')")] = None,
    kart: Annotated[str, typer.Option(help="kart preset: paper or original")] = "paper",
    conditions: Annotated[
        str,
        typer.Option(help="race conditions drawn from each race's seed: varied (launches, wear, imprecision) or paper"),
    ] = "varied",
    team_size: Annotated[
        int,
        typer.Option(
            help="karts per agent in a race: 1 head to head; 2 team races (two karts of each agent, one row, "
            "mirrored pairs of races: give an even --races-per-pair)"
        ),
    ] = 1,
    backend: Annotated[str, typer.Option(help="process (worker processes), inline or ray")] = "process",
    workers: Annotated[int | None, typer.Option(min=1, help="worker processes (default: one per CPU)")] = None,
    ray_address: Annotated[str | None, typer.Option(help="Ray cluster address (default: local Ray)")] = None,
    tournament_id: Annotated[
        str | None, typer.Option("--id", help="tournament id; an existing id with the same settings resumes")
    ] = None,
    db: DbOption = "karting.db",
    replays: Annotated[bool, typer.Option(help="store every race's replay")] = True,
    as_json: JsonOption = False,
) -> None:
    """Run a round-robin tournament, storing every race as it finishes (run it again with the same --id to
    resume an interrupted one)."""
    from arena.tournament import BACKENDS, Backend, TournamentSpec, run_tournament
    from arena.tournament import Progress as RaceProgress
    from server.tournament_db import TournamentStatus

    spec = TournamentSpec(
        _names(agents),
        _names(tracks),
        races_per_pair,
        seed,
        laps,
        time_limit,
        kart,
        conditions=conditions,
        team_size=team_size,
    )
    problems = spec.problems()
    if backend not in BACKENDS:
        problems["backend"] = f"unknown backend {backend!r}; known: {list(BACKENDS)}"
    if problems:
        for name, message in problems.items():
            error(f"{name}: {message}")
        raise typer.Exit(2)
    store = open_tournaments(db)
    tid = tournament_id or f"t{uuid.uuid4().hex[:10]}"
    try:
        stored = store.create(tid, spec)
    except ValueError as exc:
        error(str(exc))
        raise typer.Exit(2) from None
    console.print(f"tournament [bold]{tid}[/bold]: {spec.total} races, {stored.done} stored already ({db})")
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console) as bar:
        task = bar.add_task("races", total=spec.total)

        def show(progress: RaceProgress) -> None:
            last = progress.race
            text = "races" if last is None else f"races (last: {last.job.track} {' vs '.join(last.job.agents)})"
            bar.update(task, completed=progress.done, description=text)

        try:
            run_tournament(
                spec,
                store,
                tid,
                backend=cast(Backend, backend),  # checked against BACKENDS above
                workers=workers,
                ray_address=ray_address,
                record=replays,
                on_progress=show,
            )
        except KeyboardInterrupt:
            store.set_status(tid, TournamentStatus.STOPPED)
            console.print(f"stopped: run again with --id {tid} to resume")
            raise typer.Exit(130) from None
        except Exception as exc:
            store.set_status(tid, TournamentStatus.FAILED, repr(exc)[:2000])
            raise
    store.set_status(tid, TournamentStatus.FINISHED)
    result = _stats_of(store, tid)
    if as_json:
        finished = store.get(tid)
        manifest = finished.manifest.to_json() if finished is not None and finished.manifest is not None else None
        print_json({"id": tid, **result.to_json(), "manifest": manifest})
        return
    _print_wins(result)
    console.print(f"done: karting tournament report {tid} --db {db}")


def _stats_of(store: TournamentDatabase, tournament_id: str) -> TournamentStats:
    from arena.stats import tournament_stats

    if store.get(tournament_id) is None:
        error(f"no tournament {tournament_id!r}")
        raise typer.Exit(2)
    races = store.figures(tournament_id)
    if not races:
        error(f"tournament {tournament_id!r} has no finished race yet")
        raise typer.Exit(2)
    return tournament_stats(races)


def _print_wins(stats: TournamentStats) -> None:
    """Each track's win table, a compact safety table (mean (std) per metric, races finished of all) and, where
    start lanes are known, the wins by start lane."""
    from arena.report import safety_rows, start_lane_rows, win_rows
    from arena.stats import COMBINED

    for track, table in stats.tracks.items():
        if track == COMBINED and len(stats.tracks) == 2:
            continue  # one track: the same tables again
        wins = win_rows(table)
        safety = [
            [row[0], f"{row[1]} ({row[2]})", f"{row[3]} ({row[4]})", f"{row[5]} ({row[6]})", f"{row[8]}/{row[9]}"]
            for row in safety_rows(table)[1:]
        ]
        rule = table.agent_stats[table.agents[0]].illegal_lane_changes.rule
        header = ["agent", "collisions\nat fault", f"illegal lane\nchanges ({rule})", "safety\nscore", "finished"]
        tables = [(f"wins ({track})", wins), (f"safety ({track}): mean (std)", [header, *safety])]
        if table.start_lanes.races:
            tables.append((f"wins by start lane ({track})", start_lane_rows(table)))
        if table.team_pairs:
            tables.append((f"teams ({track}): per race, safety per kart-race", _team_rows(table)))
        for title, rows in tables:
            columns = [column.replace("vs ", "vs\n").replace(": ", ":\n") for column in rows[0]]
            shown = make_table(title, columns, keys=columns[:1], numeric=columns[1:])
            for row in rows[1:]:
                add_row(shown, *(str(cell) for cell in row))
            console.print(shown)


@app.command()
def stats(
    tournament_id: Annotated[str | None, typer.Option("--id", help="a stored tournament")] = None,
    original_logs: Annotated[
        Path | None, typer.Option(help="the original implementation's race logs (a folder of A_vs_B_TrackN.txt)")
    ] = None,
    teams: Annotated[
        bool, typer.Option("--teams", help="the original's team (2v2) logs (A_vs_B_TrackDuosN.txt), team-scored")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="print the stats JSON (see docs/tournaments.md)")] = False,
    db: DbOption = "karting.db",
) -> None:
    """The paper's statistics of a stored tournament, or of the original's released logs (1v1, or with
    ``--teams`` its team races as its parser scores them, with the data's defects)."""
    from arena.original_logs import read_original_logs
    from arena.stats import tournament_stats

    if (tournament_id is None) == (original_logs is None):
        error("give exactly one of --id and --original-logs")
        raise typer.Exit(2)
    if teams and original_logs is None:
        error("--teams reads the original's team logs: give --original-logs")
        raise typer.Exit(2)
    if original_logs is not None and teams:
        _team_logs(original_logs, as_json)
        return
    if original_logs is not None:
        try:
            result = tournament_stats(read_original_logs(original_logs))
        except (OSError, ValueError) as exc:
            error(str(exc))
            raise typer.Exit(2) from None
    else:
        assert tournament_id is not None
        result = _stats_of(open_tournaments(db), tournament_id)
    if as_json:
        print_json(result.to_json())
    else:
        _print_wins(result)


def _team_rows(table: TrackStats) -> list[list[str]]:
    """Each pair of teams: wins with their interval, mean points, safety per kart-race, unfinished karts, and the
    mirrored pairs of races each team won once (the grid decided)."""
    rows = [["team vs team", "wins [95%]", "points", "safety", "DNF", "mirrored: split"]]
    for pair in table.team_pairs.values():
        a, b = pair.first, pair.second
        low, high = a.wins_ci95.low if a.wins_ci95 else 0.0, a.wins_ci95.high if a.wins_ci95 else 1.0
        rows.append(
            [
                f"{a.team} vs {b.team}",
                f"{a.wins}-{b.wins} [{100 * low:.0f}, {100 * high:.0f}]%",
                f"{a.mean_points:.2f}-{b.mean_points:.2f}",
                f"{a.safety:.2f}-{b.safety:.2f}",
                f"{a.unfinished}-{b.unfinished}",
                f"{pair.split_pairs}/{pair.mirrored_pairs}",
            ]
        )
    return rows


def _team_logs(folder: Path, as_json: bool) -> None:
    """Print the original team logs' figures: per team and track as the parser counts, without copied files,
    per pairing, and the defects."""
    from arena.original_team_logs import read_original_team_logs, team_logs_report

    try:
        report = team_logs_report(read_original_team_logs(folder))
    except (OSError, ValueError) as exc:
        error(str(exc))
        raise typer.Exit(2) from None
    if as_json:
        print_json(report)
        return
    columns = ["team", "races", "wins [95%]", "team pts", "coll.", "ILC", "safety", "DNF"]
    for source, label in (
        ("parser", "as the original's parser counts (copied file included)"),
        ("genuine", "genuine files only"),
    ):
        for track, figures in cast(dict[str, dict[str, dict[str, object]]], report[source]).items():
            shown = make_table(f"{track}, {label}: per kart-race", columns, keys=columns[:1], numeric=columns[1:])
            for team, f in figures.items():
                low, high = cast(list[float], f["wins_ci95"])
                add_row(
                    shown,
                    team,
                    str(f["races"]),
                    f"{f['wins']} = {100 * cast(float, f['win_rate']):.1f}% [{100 * low:.0f}, {100 * high:.0f}]",
                    f"{f['mean_points']:.2f}",
                    f"{f['collisions_per_kart_race']:.3f}",
                    f"{f['illegal_lane_changes_per_kart_race']:.3f}",
                    f"{f['safety_per_kart_race']:.3f}",
                    str(f["unfinished_karts"]),
                )
            console.print(shown)
    pairs = make_table(
        "pairings (genuine files): A-B", ["track", "A vs B", "wins", "points wins", "team pts", "coll.", "ILC", "DNF"]
    )
    for m in cast(list[dict[str, object]], report["matchups"]):
        a, b = cast(list[dict[str, object]], m["figures"])
        pw = cast(list[int], m["points_wins"])
        add_row(
            pairs,
            str(m["track"]),
            " vs ".join(cast(list[str], m["teams"])),
            f"{a['wins']}-{b['wins']}",
            f"{pw[0]}-{pw[1]}",
            f"{a['mean_points']:.2f} / {b['mean_points']:.2f}",
            f"{a['collisions_per_kart_race']:.2f} / {b['collisions_per_kart_race']:.2f}",
            f"{a['illegal_lane_changes_per_kart_race']:.2f} / {b['illegal_lane_changes_per_kart_race']:.2f}",
            f"{a['unfinished_karts']} / {b['unfinished_karts']}",
        )
    console.print(pairs)
    console.print("defects of the data:")
    for defect in cast(list[str], report["defects"]):
        console.print(f"  - {defect}", soft_wrap=True, markup=False)


@app.command()
def report(
    tournament_id: Annotated[str, typer.Argument(help="a stored tournament")],
    out: Annotated[Path | None, typer.Option(help="output folder (default runs/tournaments/ID)")] = None,
    db: DbOption = "karting.db",
    as_json: JsonOption = False,
) -> None:
    """Write a tournament's report: Markdown, CSV and JSON tables like the paper's, PNG plots and the
    tournament's manifest (``manifest.json``: commit, agents with every parameter, kart, conditions)."""
    import json

    from arena.report import write_report

    store = open_tournaments(db)
    result = _stats_of(store, tournament_id)
    stored = store.get(tournament_id)
    assert stored is not None
    folder = out or Path("runs") / "tournaments" / tournament_id
    title = f"Tournament {tournament_id} ({stored.done}/{stored.total} races, {stored.status.value})"
    files = write_report(result, store.figures(tournament_id), folder, title)
    if stored.manifest is not None:
        files.append(folder / "manifest.json")
        files[-1].write_text(json.dumps(stored.manifest.to_json(), indent=1) + "\n")
    if as_json:
        print_json({"id": tournament_id, "folder": str(folder), "files": [str(f) for f in files]})
        return
    console.print(f"wrote {len(files)} files to {folder}")


@app.command()
def publish(
    tournament_id: Annotated[str, typer.Argument(help="a stored, finished tournament")],
    out: Annotated[Path, typer.Option(help="the results folder")] = Path("docs/results"),
    readme: Annotated[
        Path, typer.Option(help="the README whose <!-- results:begin --> ... <!-- results:end --> block gets the table")
    ] = Path("README.md"),
    no_readme: Annotated[bool, typer.Option("--no-readme", help="leave the README as it is")] = False,
    db: DbOption = "karting.db",
    as_json: JsonOption = False,
) -> None:
    """Publish a finished tournament as the project's results: its report, a README saying what was run and
    manifest.json (commit, agents with every parameter, conditions, each file's SHA-256) into OUT, and its win
    table into the README's results block. Refused (exit 2, nothing written) when the tournament is unfinished,
    has no manifest, or its agents' parameters or weights differ from the registry's now."""
    from rich.markup import escape

    from arena.publish import PublishError
    from arena.publish import publish as publish_results

    tournament = open_tournaments(db).publishable(tournament_id)
    if tournament is None:
        error(f"no tournament {tournament_id!r}")
        raise typer.Exit(2)
    try:
        files = publish_results(tournament, out, None if no_readme else readme)
    except PublishError as exc:
        error(f"cannot publish {tournament_id}:\n{escape(str(exc))}")
        raise typer.Exit(2) from None
    if as_json:
        shown = {"id": tournament_id, "folder": str(out), "files": [str(f) for f in files]}
        print_json({**shown, "readme": None if no_readme else str(readme)})
        return
    console.print(f"wrote {len(files)} files to {out}" + ("" if no_readme else f" and the results table to {readme}"))
