"""A tournament's report: the paper's appendix tables as Markdown, CSV and JSON, and PNG plots (win-matrix
heatmaps, safety bars with error bars, finish-time distributions) drawn with matplotlib's Agg backend.

Tables are laid out like the paper's: wins row agent against column agent, ``*`` where the pair's binomial test
is significant; safety per agent as mean (std. dev.) with ``*`` where the agent differs significantly from every
other agent; the ``Races`` column is the races the agent finished (of ``races`` in all).
"""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from arena.records import RaceFigures
from arena.stats import ALPHA, COMBINED, SAFETY_METRICS, MeanStd, TournamentStats, TrackStats

if TYPE_CHECKING:
    from matplotlib.figure import Figure

METRIC_TITLES = {
    "collisions_at_fault": "collisions-at-fault",
    "illegal_lane_changes": "illegal lane changes",
    "safety_score": "safety score",
    "delta_r": "Δr [m]",
    "delta_v": "Δv [m/s]",
}


def _fmt(summary: MeanStd | None, mark: bool = False) -> tuple[str, str]:
    """(mean with its 95% interval, std. dev.)."""
    if summary is None:
        return "-", "-"
    interval = f" [{summary.ci95.low:.3g}, {summary.ci95.high:.3g}]" if summary.ci95 is not None else ""
    return f"{summary.mean:.3g}{'*' if mark else ''}{interval}", f"{summary.std:.3g}"


def pair_rows(table: TrackStats) -> list[list[str]]:
    """Per pair (in the agents' order): the races, the first agent's win rate with its 95% Wilson interval, the
    distinct outcomes of the pair's races, and how much the grid explains: the first agent's wins from each start
    lane and Fisher's exact test of the lane's effect (``*``: p < 0.05)."""
    rows = [["pair", "races", "win rate of the first [95% CI]", "distinct outcomes", "wins from lane 2 / 3", "lane p"]]
    for i, a in enumerate(table.agents):
        for b in table.agents[i + 1 :]:
            rate = table.win_rate(a, b)
            pair = table.pairs.get(frozenset((a, b)))
            if rate is None or pair is None:
                continue
            value, interval = rate
            split = table.start_lanes.pairs.get((a, b))
            lanes = "-"
            p = "-"
            if split is not None:
                lanes = " / ".join(
                    f"{r.wins} of {r.races}" if (r := split.by_lane.get(lane)) else "-" for lane in (2, 3)
                )
                if split.fisher_p is not None:
                    p = f"{split.fisher_p:.2g}{'*' if split.fisher_p < ALPHA else ''}"
            cells = [f"{a} vs {b}", str(pair.races), f"{100 * value:.0f}% [{100 * interval.low:.0f}, "]
            cells[-1] += f"{100 * interval.high:.0f}]"
            rows.append([*cells, str(pair.distinct_outcomes), lanes, p])
    return rows


def rating_rows(stats: TournamentStats) -> list[list[str]]:
    """The leaderboard: every agent's Plackett-Luce rating (log-strength, centred) with its 95% interval."""
    rows = [["rank", "agent", "rating θ [95% CI]", "races"]]
    for rank, rating in enumerate(stats.ratings, start=1):
        interval = f" [{rating.ci95.low:.2f}, {rating.ci95.high:.2f}]" if rating.ci95 else ""
        rows.append([str(rank), rating.agent, f"{rating.theta:.2f}{interval}", str(rating.races)])
    return rows


def win_rows(table: TrackStats) -> list[list[str]]:
    """The win table: a header row, then per agent its wins against every column agent (``*``: significant)."""
    rows = [["agent", *(f"vs {b}" for b in table.agents)]]
    for a in table.agents:
        cells = [a]
        for b in table.agents:
            test = table.win_test(a, b)
            if a == b or b not in table.wins[a]:
                cells.append("-")
            else:
                cells.append(f"{table.wins[a][b]}{'*' if test is not None and test.significant else ''}")
        rows.append(cells)
    return rows


def safety_rows(table: TrackStats) -> list[list[str]]:
    """The safety table: per agent mean (std) of each safety metric, the counting rule, races finished/all."""
    header = ["agent"]
    for metric in SAFETY_METRICS:
        header += [f"avg. {METRIC_TITLES[metric]}", f"std. dev. {METRIC_TITLES[metric]}"]
    rows = [[*header, "lane-change rule", "races finished", "races"]]
    for a in table.agents:
        figures = table.agent_stats[a]
        summaries = (figures.collisions_at_fault, figures.illegal_lane_changes.headline, figures.safety_score)
        cells = [a]
        for metric, summary in zip(SAFETY_METRICS, summaries, strict=True):
            cells += list(_fmt(summary, table.marked(metric, a)))
        rows.append([*cells, figures.illegal_lane_changes.rule, str(figures.finished), str(figures.races)])
    return rows


def plan_rows(table: TrackStats) -> list[list[str]]:
    """Plan following and passes: Δr, Δv over finished races (samples), passes per race."""
    rows = [["agent", "Δr [m]", "std. dev.", "Δv [m/s]", "std. dev.", "samples", "passes", "std. dev."]]
    for a in table.agents:
        figures = table.agent_stats[a]
        dr = _fmt(figures.delta_r, figures.delta_r is not None and table.marked("delta_r", a))
        dv = _fmt(figures.delta_v, figures.delta_v is not None and table.marked("delta_v", a))
        samples = str(figures.delta_r.n) if figures.delta_r else "0"
        rows.append([a, *dr, *dv, samples, *_fmt(figures.passes)])
    return rows


def start_lane_rows(table: TrackStats) -> list[list[str]]:
    """Wins by start lane (races with known start lanes): per pair (row agent first), the first agent's wins–losses
    from each of its start lanes and Fisher's exact test of whether they depend on the lane (``*``: p < 0.05); a
    last row with the wins–losses of whichever kart started in each lane. Only the header when no race has
    known start lanes."""
    lanes = list(table.start_lanes.by_lane)
    rows = [["pair", *(f"from lane {lane}: wins–losses" for lane in lanes), "Fisher p"]]
    for (a, b), split in table.start_lanes.pairs.items():
        if table.agents.index(a) > table.agents.index(b):
            continue
        cells = [f"{a} vs {b}"]
        for lane in lanes:
            record = split.by_lane.get(lane)
            cells.append("-" if record is None else f"{record.wins}–{record.losses}")
        p = split.fisher_p
        cells.append("-" if p is None else f"{p:.2g}{'*' if p < ALPHA else ''}")
        rows.append(cells)
    if lanes:
        records = table.start_lanes.by_lane.values()
        rows.append(["any kart", *(f"{r.wins}–{r.losses}" for r in records), "-"])
    return rows


def markdown_table(rows: Sequence[Sequence[str]]) -> str:
    """``rows`` (the first the header) as a Markdown table."""
    lines = ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
    lines += ["| " + " | ".join(row) + " |" for row in rows[1:]]
    return "\n".join(lines)


def markdown(stats: TournamentStats, title: str) -> str:
    """The whole report as Markdown."""
    parts = [f"# {title}", ""]
    if stats.ratings:
        parts += ["## Ratings from every race (Plackett-Luce; a beats b with probability 1 / (1 + e^(θb - θa)))", ""]
        parts += [markdown_table(rating_rows(stats)), ""]
    for track, table in stats.tracks.items():
        name = "All tracks" if track == COMBINED else f"Track `{track}`"
        parts += [f"## {name}", "", "### Head-to-head wins, row agent against column agent", ""]
        parts += [
            markdown_table(win_rows(table)),
            "",
            "### Pairs: win rates with 95% intervals, and the grid's part",
            "",
        ]
        parts += [
            markdown_table(pair_rows(table)),
            "",
            "### Safety per race: mean [95% CI] and std. dev., all races",
            "",
        ]
        parts += [markdown_table(safety_rows(table)), "", "### Plan following (finished races) and passes", ""]
        parts += [markdown_table(plan_rows(table)), ""]
        if table.start_lanes.races:
            parts += ["### Wins by start lane (row pair's first agent; Fisher's exact test of the lane's effect)", ""]
            parts += [markdown_table(start_lane_rows(table)), ""]
    parts += [
        "`*`: significant at p = 0.05 (wins: two-sided binomial test of the pair's decided races; per-race figures: "
        "two-sided pooled t-tests, marked when significant against every other agent; start lanes: Fisher's exact "
        "test, two-sided). Intervals: 95%, Wilson for win rates, percentile bootstrap for means.",
        "",
    ]
    return "\n".join(parts)


def _write_csv(path: Path, rows: Sequence[Sequence[str]]) -> Path:
    with path.open("w", newline="") as handle:
        csv.writer(handle).writerows(rows)
    return path


def write_report(stats: TournamentStats, races: Sequence[RaceFigures], out: str | Path, title: str) -> list[Path]:
    """Write ``report.md``, ``stats.json``, CSV tables and PNG plots into ``out``; returns the files written."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    written = [folder / "report.md", folder / "stats.json"]
    written[0].write_text(markdown(stats, title))
    written[1].write_text(json.dumps(stats.to_json(), indent=1))
    for track, table in stats.tracks.items():
        written.append(_write_csv(folder / f"wins_{track}.csv", win_rows(table)))
        written.append(_write_csv(folder / f"safety_{track}.csv", safety_rows(table)))
        written.append(_write_csv(folder / f"plan_{track}.csv", plan_rows(table)))
        written.append(_write_csv(folder / f"start_lanes_{track}.csv", start_lane_rows(table)))
        written.append(_write_csv(folder / f"pairs_{track}.csv", pair_rows(table)))
    written += plot_report(stats, races, folder)
    return written


def plot_stem(kind: str, track: str | None = None) -> str:
    """A plot's file name without ``.png``: ``wins_TRACK``, ``safety_TRACK`` or ``finish_times`` (characters other
    than letters, digits, ``-`` and ``_`` in a track's name, as a path's slashes, become ``_``)."""
    return kind if track is None else f"{kind}_{re.sub(r'[^A-Za-z0-9_-]', '_', track)}"


def plot_stems(stats: TournamentStats) -> list[str]:
    """The stems of the plots :func:`plot_report` draws for ``stats``, in its order."""
    stems = [plot_stem(kind, track) for track in stats.tracks for kind in ("wins", "safety")]
    return [*stems, plot_stem("finish_times")]


def plot_report(stats: TournamentStats, races: Sequence[RaceFigures], folder: Path) -> list[Path]:
    """The PNG plots: a win-matrix heatmap and safety bars per track, and the finish-time distributions
    (:func:`plot_stems` names them)."""
    plt = _pyplot()
    written = []
    for track, table in stats.tracks.items():
        agents = table.agents
        matrix = [
            [float(table.wins[a].get(b, float("nan"))) if a != b else float("nan") for b in agents] for a in agents
        ]
        fig, ax = plt.subplots(figsize=(1.4 * len(agents) + 2, 1.1 * len(agents) + 1.5))
        image = ax.imshow(matrix, cmap="viridis")
        ax.set_xticks(range(len(agents)), [f"vs {b}" for b in agents], rotation=30, ha="right")
        ax.set_yticks(range(len(agents)), agents)
        for i, row in enumerate(win_rows(table)[1:]):
            for j, cell in enumerate(row[1:]):
                ax.text(j, i, cell, ha="center", va="center", color="white" if cell != "-" else "grey")
        fig.colorbar(image, ax=ax, label="wins")
        ax.set_title(f"Head-to-head wins ({track})")
        fig.tight_layout()
        written.append(_save(fig, folder / f"{plot_stem('wins', track)}.png", plt))

        fig, ax = plt.subplots(figsize=(8, 4))
        width = 0.8 / len(SAFETY_METRICS)
        for m, metric in enumerate(SAFETY_METRICS):
            summaries = [getattr(table.agent_stats[a], metric) for a in agents]
            means = [s.headline.mean if metric == "illegal_lane_changes" else s.mean for s in summaries]
            stds = [s.headline.std if metric == "illegal_lane_changes" else s.std for s in summaries]
            positions = [i + (m - 1) * width for i in range(len(agents))]
            ax.bar(positions, means, width, yerr=stds, capsize=3, label=METRIC_TITLES[metric])
        ax.set_xticks(range(len(agents)), agents, rotation=20)
        ax.set_ylabel("per race (mean, error bar: std. dev.)")
        ax.set_ylim(bottom=0)
        ax.legend()
        ax.set_title(f"Safety ({track})")
        fig.tight_layout()
        written.append(_save(fig, folder / f"{plot_stem('safety', track)}.png", plt))
    written.append(_finish_times(stats, races, folder, plt))
    return written


def _pyplot() -> ModuleType:
    """matplotlib's pyplot on the Agg backend (files only; loaded on use: reports are the only plots)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot

    return pyplot


def _finish_times(stats: TournamentStats, races: Sequence[RaceFigures], folder: Path, plt: ModuleType) -> Path:
    tracks = [t for t in stats.tracks if t != COMBINED]
    fig, axes = plt.subplots(1, len(tracks), figsize=(6 * len(tracks), 4), squeeze=False)
    for ax, track in zip(axes[0], tracks, strict=True):
        agents = stats.tracks[track].agents
        times = [
            [k.total_time for r in races if r.track == track for k in r.karts if k.agent == a and k.total_time]
            for a in agents
        ]
        shown = [(a, t) for a, t in zip(agents, times, strict=True) if t]
        if shown:
            ax.boxplot([t for _, t in shown], tick_labels=[f"{a}\n({len(t)})" for a, t in shown])
        ax.set_title(f"Finish times ({track}; finished races)")
        ax.set_ylabel("race time [s]")
    fig.tight_layout()
    return _save(fig, folder / f"{plot_stem('finish_times')}.png", plt)


def _save(fig: Figure, path: Path, plt: ModuleType) -> Path:
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
