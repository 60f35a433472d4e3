"""Per-pairing table of a stored tournament: for each track and pair, wins, finished, mean finish time,
collisions at fault and illegal lane changes (per-step rule) per race of each side.

    .venv/bin/python scripts/pair_table.py paper-grid-20 --db karting.db

Prints a Markdown table and, as the last line, one JSON object of the same figures.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np

from arena.records import KartFigures
from server.db import RaceDatabase
from server.tournament_db import TournamentDatabase


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("tournament")
    parser.add_argument("--db", required=True, help="SQLite file")
    args = parser.parse_args()
    db = TournamentDatabase(RaceDatabase(args.db if "://" in args.db else f"sqlite:///{args.db}"))
    cells: dict[tuple[str, str, str], list] = defaultdict(list)
    for race in db.figures(args.tournament):
        a, b = sorted(race.agents)
        cells[(race.track, a, b)].append(race)
    out: list[dict[str, object]] = []
    header = ["track", "A vs B", "wins A-B", "finished A / B", "mean finish A / B [s]", "faults/race A / B"]
    print("| " + " | ".join([*header, "illegal/race A / B"]) + " |")
    print("|---|---|---|---|---|---|---|")
    for (track, a, b), races in sorted(cells.items()):
        side: dict[str, list[KartFigures]] = {a: [], b: []}
        for race in races:
            for kart in race.karts:
                side[kart.agent].append(kart)
        wins = {a: sum(r.winner() == a for r in races), b: sum(r.winner() == b for r in races)}

        def mean(values: list[float]) -> float | None:
            return round(float(np.mean(values)), 2) if values else None

        finished = [sum(k.finished for k in side[x]) for x in (a, b)]
        times = [mean([k.total_time for k in side[x] if k.finished and k.total_time]) for x in (a, b)]
        faults = [mean([k.collisions_at_fault for k in side[x]]) for x in (a, b)]
        illegal = [mean([k.illegal_lane_changes.get("per_step", 0) for k in side[x]]) for x in (a, b)]
        row = {
            "track": track.split("/")[-1],
            "a": a,
            "b": b,
            "races": len(races),
            "wins": [wins[a], wins[b]],
            "finished": finished,
            "mean_finish_s": times,
            "faults_per_race": faults,
            "illegal_per_race": illegal,
        }
        out.append(row)
        f, t, c, i = finished, times, faults, illegal
        print(
            f"| {row['track']} | {a} vs {b} | {wins[a]}-{wins[b]} | {f[0]}/{len(races)} / {f[1]}/{len(races)} "
            f"| {t[0]} / {t[1]} | {c[0]} / {c[1]} | {i[0]} / {i[1]} |"
        )
    print(json.dumps(out))


if __name__ == "__main__":
    main()
