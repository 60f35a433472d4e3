"""``karting scenarios``: the tactics suite (:mod:`arena.scenarios`): list the scenarios, run cells of them, and
report a stored run as tables."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from karting.output import add_row, console, error, print_json, table

app = typer.Typer(help="Tactical scenarios: overtaking and defending from placed karts.", no_args_is_help=True)

CSV = Annotated[str, typer.Option(help="comma separated")]


def _split(text: str) -> list[str]:
    return [part.strip() for part in text.split(",") if part.strip()]


@app.command("list")
def list_scenarios() -> None:
    """The shipped scenarios (``scenarios/*.json``) and what each measures."""
    from arena.scenario_spec import load_scenario, shipped_scenarios

    shown = table("scenarios", ["name", "kind", "place", "tracks", "paces", "description"], keys=["name"])
    for name in shipped_scenarios():
        s = load_scenario(name)
        paces = ", ".join(f"{p:g}" for p in s.paces)
        add_row(shown, s.name, s.kind, s.place, ", ".join(s.tracks), paces, s.description)
    console.print(shown)


@app.command()
def run(
    scenarios: CSV = "overtake-straight",
    egos: CSV = "mcts-lqng,mcts-rl",
    opponents: CSV = "fixed-lqng,fixed-rl,e2e",
    tracks: Annotated[str | None, typer.Option(help="comma separated (default: each scenario's)")] = None,
    paces: Annotated[str | None, typer.Option(help="comma separated (default: each scenario's ladder)")] = None,
    attempts: Annotated[int, typer.Option(min=1, max=1000, help="seeded attempts per cell")] = 30,
    seed: int = 0,
    workers: Annotated[int, typer.Option(min=1, help="worker processes the cells are dealt to")] = 1,
    out: Annotated[Path | None, typer.Option(help="also write the JSON summary here")] = None,
    publish: Annotated[
        Path | None, typer.Option(help="publish the summary, its report and a manifest into this folder")
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the JSON summary as the last line")] = False,
) -> None:
    """Race ATTEMPTS attempts of every cell (scenario, track, ego, opponent, pace): scenarios by shipped name or
    file path; an ego never meets itself. Prints each cell's success rate with its 95% interval, the time to pass,
    the ego's collisions at fault and illegal lane changes per attempt, and each ego's pass threshold r50."""
    from arena.scenario_spec import load_scenario
    from arena.scenarios import SuiteResult, cells_of, run_cells

    try:
        loaded = [load_scenario(name) for name in _split(scenarios)]
        pace_list = [float(p) for p in _split(paces)] if paces else None
        track_list = _split(tracks) if tracks else None
        plans = [(s, cells_of(s, _split(egos), _split(opponents), track_list, pace_list)) for s in loaded]
    except (KeyError, ValueError) as exc:
        error(str(exc).strip("'\""))
        raise typer.Exit(2) from None
    total = sum(len(cells) for _, cells in plans) * attempts
    console.print(f"{total} attempts in {sum(len(c) for _, c in plans)} cells", style="dim")
    started = time.perf_counter()
    runs = tuple((s, tuple(run_cells(s, cells, attempts, seed, workers=workers))) for s, cells in plans)
    wall = time.perf_counter() - started
    summary = SuiteResult(runs, attempts, seed).to_json()
    summary["command"] = " ".join(
        f"--{name} {value}"
        for name, value in (
            ("scenarios", scenarios),
            ("egos", egos),
            ("opponents", opponents),
            ("tracks", tracks),
            ("paces", paces),
            ("attempts", attempts),
            ("seed", seed),
            ("publish", publish),
        )
        if value is not None
    )
    _show(summary)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(summary, indent=1) + "\n")
    if publish is not None:
        from arena.scenario_report import publish as publish_summary

        publish_summary(summary, publish, [*_split(egos), *_split(opponents)], wall)
        console.print(f"published into {publish}/")
    if as_json:
        print_json(summary)


@app.command()
def oracle(
    scenarios: CSV = "overtake-straight",
    opponents: CSV = "fixed-lqng,fixed-rl,e2e,mcts-lqng,mcts-rl",
    tracks: Annotated[str | None, typer.Option(help="comma separated (default: each scenario's)")] = None,
    paces: Annotated[str | None, typer.Option(help="comma separated (default: each scenario's ladder)")] = None,
    attempts: Annotated[int, typer.Option(min=1, max=1000, help="seeded attempts per cell")] = 10,
    seed: int = 0,
    lookahead: Annotated[float, typer.Option(min=0.5, max=10.0, help="[s] each candidate raced forward")] = 4.0,
    base: Annotated[str, typer.Option(help="the hierarchical agent whose plans the oracle improves on")] = "mcts-lqng",
    workers: Annotated[int, typer.Option(min=1, help="worker processes the cells are dealt to")] = 1,
    out: Annotated[Path | None, typer.Option(help="also write the JSON summary here")] = None,
    publish: Annotated[
        Path | None, typer.Option(help="publish the summary, its report and a manifest into this folder")
    ] = None,
    beside: Annotated[
        list[Path] | None,
        typer.Option(help="agents' summaries (`run --out` or a published summary.json) to report beside the oracle"),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="print the JSON summary as the last line")] = False,
) -> None:
    """The oracle bound (:mod:`arena.oracle`): the same attempts as ``run``, the ``--base`` agent as the ego with
    each of its plans replaced by whichever of it and its held-lane variants ends furthest ahead when raced forward
    in the simulator against the opponent's own controller."""
    from arena.oracle import ORACLE, OracleSettings, check_two_karts, oracle_driver, run_oracle_cells
    from arena.scenario_spec import Cell, load_scenario
    from arena.scenarios import SuiteResult
    from controllers.registry import validate_agent
    from sim_core.params import MIN_PACE

    try:
        loaded = [load_scenario(name) for name in _split(scenarios)]
        for scenario in loaded:
            check_two_karts(scenario)
        for opponent in _split(opponents):
            validate_agent(opponent)
        settings = OracleSettings(lookahead_s=lookahead, base=base)
        oracle_driver(settings)  # a ValueError unless the base is a registered hierarchical agent
        agents_beside = [json.loads(path.read_text()) for path in beside or ()]
        if paces and not all(MIN_PACE <= float(p) <= 1.0 for p in _split(paces)):
            raise ValueError(f"paces must be in [{MIN_PACE}, 1]")
        plans = [
            (
                s,
                [
                    Cell(s.name, track, ORACLE, opponent, float(pace))
                    for track in (_split(tracks) if tracks else s.tracks)
                    for opponent in _split(opponents)
                    for pace in (_split(paces) if paces else s.paces)
                ],
            )
            for s in loaded
        ]
    except (KeyError, ValueError, OSError, json.JSONDecodeError) as exc:
        error(str(exc).strip("'\""))
        raise typer.Exit(2) from None
    console.print(f"{sum(len(c) for _, c in plans) * attempts} oracle attempts", style="dim")
    started = time.perf_counter()
    runs = tuple((s, tuple(run_oracle_cells(s, cells, attempts, seed, settings, workers))) for s, cells in plans)
    wall = time.perf_counter() - started
    summary = SuiteResult(runs, attempts, seed).to_json()
    summary["oracle"] = {"lookahead_s": settings.lookahead_s, "base": settings.base}
    summary["subcommand"] = "oracle"
    summary["command"] = " ".join(
        f"--{name} {value}"
        for name, value in (
            ("scenarios", scenarios),
            ("opponents", opponents),
            ("tracks", tracks),
            ("paces", paces),
            ("attempts", attempts),
            ("seed", seed),
            ("lookahead", lookahead),
            ("base", base),
            ("publish", publish),
            *(("beside", path) for path in beside or ()),
        )
        if value is not None
    )
    _show(summary)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(summary, indent=1) + "\n")
    if publish is not None:
        from arena.scenario_report import publish as publish_summary

        publish_summary(summary, publish, [base, *_split(opponents)], wall, beside=agents_beside)
        console.print(f"published into {publish}/")
    if as_json:
        print_json(summary)


@app.command("staircase")
def staircase_command(
    ego: Annotated[str, typer.Option(help="the agent that passes")],
    opponent: Annotated[str, typer.Option(help="the leader, at the staircase's pace")],
    track: str = "oval",
    scenario: Annotated[str, typer.Option(help="an overtaking scenario, shipped or a file")] = "overtake-straight",
    trials: Annotated[int, typer.Option(min=1, max=500)] = 30,
    start: Annotated[float, typer.Option(help="the first leader pace")] = 0.95,
    step: Annotated[float, typer.Option(help="the pace step after each trial")] = 0.01,
    seed: int = 0,
    as_json: Annotated[bool, typer.Option("--json", help="print the result as JSON, the last line")] = False,
) -> None:
    """The pass threshold r50 by a staircase: after a pass the leader gets faster by STEP, after a failure slower;
    r50 is the mean pace of the reversals after the first two, with a 95% bootstrap interval."""
    from arena.staircase import pass_staircase

    try:
        result = pass_staircase(load_scenario_or_exit(scenario), track, ego, opponent, trials, start, step, seed)
    except (KeyError, ValueError) as exc:
        error(str(exc).strip("'\""))
        raise typer.Exit(2) from None
    marks = " ".join(f"{p:g}{'+' if ok else '-'}" for p, ok in zip(result.paces, result.passed, strict=True))
    console.print(f"trials (pace, + passed): {marks}")
    ci = "" if result.ci95 is None else f" [{result.ci95.low:.3f}, {result.ci95.high:.3f}]"
    r50 = "too few reversals" if result.r50 is None else f"{result.r50:.3f}{ci}"
    console.print(f"r50 of {ego} behind {opponent} on {track}: {r50} ({len(result.reversals)} reversals)")
    if as_json:
        print_json({"ego": ego, "opponent": opponent, "track": track, "scenario": scenario, **result.to_json()})


def load_scenario_or_exit(name: str) -> Any:
    """A scenario by name or path; exit code 2 naming the shipped ones when there is none."""
    from arena.scenario_spec import load_scenario

    try:
        return load_scenario(name)
    except (KeyError, ValueError) as exc:
        error(str(exc).strip("'\""))
        raise typer.Exit(2) from None


@app.command()
def report(
    summary: Annotated[Path, typer.Argument(help="a JSON summary written by `karting scenarios run --out`")],
    markdown: Annotated[Path | None, typer.Option(help="write the tables as Markdown here")] = None,
) -> None:
    """Show a stored run's tables (and write them as Markdown)."""
    try:
        data = json.loads(summary.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        error(f"cannot read {summary}: {exc}")
        raise typer.Exit(2) from None
    _show(data)
    if markdown is not None:
        from arena.scenario_report import markdown_report

        markdown.write_text(markdown_report(data))
        console.print(f"wrote {markdown}")


def _show(summary: dict[str, Any]) -> None:
    from arena.scenario_report import cell_row, shows_place

    with_place = shows_place(summary)
    columns = [
        "scenario",
        "track",
        "ego",
        "opponent",
        "pace",
        "n",
        "success [95% CI]",
        "to pass [s]",
        "faults",
        "illegal",
        *(["place [95% CI]"] if with_place else []),
    ]
    shown = table("cells", columns, keys=["ego", "opponent"], numeric=["pace", "n", "to pass [s]"])
    for cell in summary["cells"]:
        add_row(shown, *cell_row(cell, with_place))
    console.print(shown)
    thresholds = table(
        "pass threshold r50 (highest leader pace passed in half the attempts)", ["ego", "opponent", "r50"]
    )
    for ego, row in summary["pass_threshold_r50"].items():
        for opponent, r50 in row.items():
            add_row(thresholds, ego, opponent, "below every pace" if r50 is None else f"{r50:g}")
    console.print(thresholds)
