"""The five 50-race series of mcts-lqng with ``rollout_check_depth=3`` against fixed-lqng, put together from the
files of sessions 26 and 27 (one JSON line per race, as results/issue11/session26/checked_series.py writes them),
and the short series against the grid's other opponents (``vs_grid/``), with the check and without.

    .venv/bin/python results/issue11/session27/summarise.py > results/issue11/session27/series_summary.md
"""

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FILES = {
    "complex": ["session26/checked_series_complex.jsonl", "session26/checked_series_complex_10-49.jsonl"],
    "oval": ["session26/device2/checked_series_oval.jsonl", "session27/checked_series_oval_10-49.jsonl"],
    "complex-reversed": [
        "session26/checked_series_complex-reversed.jsonl",
        "session27/checked_series_complex-reversed_20-49.jsonl",
    ],
    "oval-reversed": [
        "session26/checked_series_oval-reversed.jsonl",
        "session27/checked_series_oval-reversed_10-17.jsonl",
        "session27/checked_series_oval-reversed_18-49.jsonl",
    ],
    "kidney (imported, never tuned on)": [
        "session26/device2/checked_series_kidney.jsonl",
        "session27/checked_series_kidney_17-49.jsonl",
    ],
}


def rows(paths: list[str]) -> list[dict[str, object]]:
    """Every race line of ``paths`` (missing files skipped), one per seed."""
    found: dict[int, dict[str, object]] = {}
    for path in paths:
        file = ROOT / path
        if not file.exists():
            continue
        for line in file.read_text().splitlines():
            if line.startswith('{"seed"'):
                row = json.loads(line)
                found[int(row["seed"])] = row
    return [found[seed] for seed in sorted(found)]


def mean(races: list[dict[str, object]], key: str, kart: int) -> float:
    """The mean of ``key``'s entry for ``kart`` over ``races``."""
    return sum(float(r[key][kart]) for r in races) / len(races)  # type: ignore[index]


def main() -> None:
    print(
        "| track | races | mcts-lqng wins (lane 2 / lane 3 starts) | mean finish mcts-lqng / fixed-lqng [s] |"
        " collisions at fault per race (mcts-lqng / fixed-lqng) | illegal lane changes per race (mcts-lqng) |"
        " passes per race (mcts-lqng / fixed-lqng) | seeds |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for track, paths in FILES.items():
        races = rows(paths)
        n = len(races)
        if not n:
            continue
        wins = [r for r in races if r["winner"] == 0]
        by_lane = {lane: sum(1 for r in wins if r["lanes"][0] == lane) for lane in (2, 3)}  # type: ignore[index]
        starts = {lane: sum(1 for r in races if r["lanes"][0] == lane) for lane in (2, 3)}  # type: ignore[index]

        seeds = [int(r["seed"]) for r in races]  # type: ignore[arg-type]
        times = f"{mean(races, 'time', 0):.2f} / {mean(races, 'time', 1):.2f}"
        faults = f"{mean(races, 'faults', 0):.2f} / {mean(races, 'faults', 1):.2f}"
        passes = f"{mean(races, 'passes', 0):.2f} / {mean(races, 'passes', 1):.2f}"
        won = f"**{len(wins)}** ({by_lane[2]} of {starts[2]} / {by_lane[3]} of {starts[3]})"
        illegal = f"{mean(races, 'illegal', 0):.2f}"
        print(f"| `{track}` | {n} | {won} | {times} | {faults} | {illegal} | {passes} | {min(seeds)}-{max(seeds)} |")


def vs_grid() -> None:
    """One row per opponent and track: mcts-lqng as registered and with the check, from ``vs_grid/``."""
    folder = ROOT / "session27" / "vs_grid"
    print()
    print(
        "| opponent | track | as registered: wins (lane 2 / lane 3) · mean finish · at fault per race |"
        " with the check: wins (lane 2 / lane 3) · mean finish · at fault per race |"
    )
    print("|---|---|---|---|")
    won = {0: 0, 3: 0}
    raced = {0: 0, 3: 0}
    for opponent in ("e2e", "fixed-rl", "mcts-rl"):
        for track in ("complex", "oval"):
            cells = []
            for depth in (0, 3):
                races = rows([f"session27/vs_grid/{track}_{opponent}_depth{depth}.jsonl"])
                if not races or not (folder / f"{track}_{opponent}_depth{depth}.jsonl").exists():
                    cells.append("—")
                    continue
                wins = {lane: sum(1 for r in races if r["winner"] == 0 and r["lanes"][0] == lane) for lane in (2, 3)}  # type: ignore[index]
                total = wins[2] + wins[3]
                won[depth] += total
                raced[depth] += len(races)
                cells.append(
                    f"{total} of {len(races)} ({wins[2]} / {wins[3]}) · {mean(races, 'time', 0):.2f} s"
                    f" / {mean(races, 'time', 1):.2f} s · {mean(races, 'faults', 0):.2f}"
                )
            print(f"| {opponent} | `{track}` | {cells[0]} | {cells[1]} |")
    print(f"| all | | **{won[0]}** of {raced[0]} | **{won[3]}** of {raced[3]} |")


if __name__ == "__main__":
    main()
    vs_grid()
