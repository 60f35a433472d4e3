"""The tactics suite's reports: a run's summary (:meth:`arena.scenarios.SuiteResult.to_json`) as table rows and
Markdown, and published with its manifest into a results folder (``karting scenarios run --publish``)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from arena.manifest import build_manifest, describe_agent
from arena.report import markdown_table
from controllers.registry import without_pace
from sim_core.conditions import condition_set

SUMMARY_FILE, REPORT_FILE, MANIFEST_FILE = "summary.json", "README.md", "manifest.json"
# what success means, by scenario kind (arena.scenario_setups.judge); overtake and defend are always explained
SUCCESS = {
    "overtake": "overtake, the ego passed (held the place 2 s) and is ahead at the end",
    "defend": "defend, the ego is still ahead at the end",
    "side-by-side": "side by side, the ego is ahead of the opponent at the end",
    "lapping": "lapping, the ego passed the slower kart and is ahead of it and the opponent at the end",
    "start": "start, the ego leads the field at the end",
}


def _interval(ci: list[float] | None) -> str:
    return "" if ci is None else f" [{ci[0]:.2f}, {ci[1]:.2f}]"


def cell_row(cell: dict[str, Any], with_place: bool = False) -> list[str]:
    """One summary cell (:meth:`CellFigures.to_json`) as table text: scenario, track, ego, opponent, pace, attempts,
    success with its interval, time to pass, collisions at fault and illegal lane changes per attempt, and with
    ``with_place`` the ego's mean place at the end with its interval."""
    to_pass = "" if cell["time_to_pass"] is None else f"{cell['time_to_pass']:.1f}"
    place = cell.get("mean_place")
    places = [""] if place is None else [f"{place:.2f}{_interval(cell.get('mean_place_ci95'))}"]
    return [
        cell["scenario"],
        cell["track"],
        cell["ego"],
        cell["opponent"],
        f"{cell['pace']:g}",
        str(cell["attempts"]),
        f"{cell['pass_success']:.2f}{_interval(cell['ci95'])}",
        to_pass,
        f"{cell['collisions_at_fault_per_attempt']:.2f}{_interval(cell['collisions_ci95'])}",
        f"{cell['illegal_lane_changes_per_attempt']:.2f}{_interval(cell['illegal_lane_changes_ci95'])}",
        *(places if with_place else []),
    ]


def shows_place(summary: dict[str, Any]) -> bool:
    """Whether the ego's place is worth a column: not for two karts placed in line (overtake, defend), whose place
    is the success."""
    return bool({scenario["kind"] for scenario in summary["scenarios"].values()} - {"overtake", "defend"})


def markdown_report(
    summary: dict[str, Any], wall_seconds: float | None = None, beside: Sequence[dict[str, Any]] = ()
) -> str:
    """A stored run (:meth:`SuiteResult.to_json`) as Markdown tables; for an oracle's run, each of the agents'
    summaries ``beside`` compared with it cell by cell (:func:`beside_oracle`)."""
    head = [
        "scenario",
        "track",
        "ego",
        "opponent",
        "pace",
        "attempts",
        "success [95% CI]",
        "time to pass [s]",
        "collisions at fault / attempt",
        "illegal lane changes / attempt",
    ]
    kinds = {scenario["kind"] for scenario in summary["scenarios"].values()}
    with_place = shows_place(summary)
    if with_place:
        head.append("ego's place [95% CI]")
    success = "; ".join(text for kind, text in SUCCESS.items() if kind in kinds | {"overtake", "defend"})
    took = "" if wall_seconds is None else f" ({wall_seconds / 60:.0f} minutes here)"
    subcommand = summary.get("subcommand", "run")
    thresholds = [
        [ego, opponent, "below every pace" if r50 is None else f"{r50:g}"]
        for ego, row in summary["pass_threshold_r50"].items()
        for opponent, r50 in row.items()
    ]
    lines = [
        f"# Scenarios: {summary['attempts']} attempts per cell, seed {summary['seed']}",
        "",
        f"Regenerate: `karting scenarios {subcommand} {summary.get('command', '...')}`{took}.",
        "",
        f"Success: {success}. Intervals: Wilson for rates, bootstrap for means.",
        "",
    ]
    if "oracle" in summary:
        settings = summary["oracle"]
        lines += [
            f"The ego `oracle` is `{settings['base']}` with each of its plans replaced by whichever of that plan and "
            f"its variants holding one lane for the next checkpoints ends furthest ahead, with no collision at fault "
            f"or illegal lane change, when raced {settings['lookahead_s']:g} s forward in a copy of the race against "
            "the opponent's own controller (`arena/oracle.py`): a bound on what lane choices could do on these "
            "attempts, not a proof of the best.",
            "",
        ]
    lines += [
        markdown_table([head, *(cell_row(cell, with_place) for cell in summary["cells"])]),
        "",
        "## Pass threshold r50",
        "",
        markdown_table([["ego", "opponent", "r50"], *thresholds]),
    ]
    for agents in beside:
        lines += ["", *beside_oracle(summary, agents)]
    return "\n".join(lines) + "\n"


def _cell_key(cell: dict[str, Any]) -> tuple[str, str, str, float]:
    return (cell["scenario"], cell["track"], cell["opponent"], float(cell["pace"]))


def beside_oracle(oracle: dict[str, Any], agents: dict[str, Any]) -> list[str]:
    """Markdown lines: each cell the oracle and the ``agents`` summary share, the oracle's success beside that of
    the ego it is built on (its base: the same tracker), and the ego's success as a share of the oracle's (where the
    oracle passed at all). The oracle's attempts are the first of the ego's (the same seeds)."""
    bound = {_cell_key(cell): cell for cell in oracle["cells"]}
    base = oracle.get("oracle", {}).get("base")
    rows = []
    for cell in agents["cells"]:
        found = bound.get(_cell_key(cell))
        if found is None or cell["ego"] != base:
            continue
        share = "" if found["pass_success"] == 0 else f"{cell['pass_success'] / found['pass_success']:.2f}"
        rows.append(
            [
                cell["track"],
                cell["opponent"],
                f"{cell['pace']:g}",
                f"{found['pass_success']:.2f}{_interval(found['ci95'])} ({found['attempts']})",
                cell["ego"],
                f"{cell['pass_success']:.2f}{_interval(cell['ci95'])} ({cell['attempts']})",
                share,
            ]
        )
    head = ["track", "opponent", "pace", "oracle (attempts)", "ego", "ego (attempts)", "ego / oracle"]
    command = agents.get("command", "")
    return [
        "## The agents beside the oracle",
        "",
        f"The agents' figures: `karting scenarios run {command}`." if command else "The agents' figures:",
        "",
        markdown_table([head, *rows]),
    ]


def publish(
    summary: dict[str, Any],
    folder: Path,
    agents: Sequence[str],
    wall_seconds: float,
    beside: Sequence[dict[str, Any]] = (),
) -> None:
    """Write ``summary`` into ``folder``: the summary JSON, its Markdown report (with the summaries ``beside``
    compared cell by cell, for an oracle's) and a manifest of the code, the agents (``agents`` and the lapping
    scenarios' slower karts: every parameter, the trained weights), the condition sets, the machine and the wall
    time."""
    folder.mkdir(parents=True, exist_ok=True)
    backmarkers = [s["backmarker"] for s in summary["scenarios"].values() if s["kind"] == "lapping"]
    described = [describe_agent(a) for a in sorted({without_pace(a) for a in (*agents, *backmarkers)})]
    sets = sorted({s["conditions"] for s in summary["scenarios"].values()})
    conditions = {"condition_sets": {name: condition_set(name).to_json() for name in sets}}
    manifest = build_manifest("scenarios", described, "paper", conditions).to_json()
    manifest["wall_seconds"] = round(wall_seconds, 1)
    (folder / SUMMARY_FILE).write_text(json.dumps(summary, indent=1) + "\n")
    (folder / REPORT_FILE).write_text(markdown_report(summary, wall_seconds, beside))
    (folder / MANIFEST_FILE).write_text(json.dumps(manifest, indent=1) + "\n")
