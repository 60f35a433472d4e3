"""MCTS-LQNG against Fixed-LQNG on the original's complex track, by start lane: wins, finish times (median) and
collisions, from the original's own logs (``MCTS_LQR_vs_Fixed_LQR_Complex3.txt``, the run the paper used) with the
start lanes of its experiment grid (``arena.original_logs.original_start_lanes``).

Run from the repo root::

    PYTHONPATH=$PWD .venv/bin/python results/issue11/session21/original_complex_by_lane.py ../shared/spec/original_logs
"""

from __future__ import annotations

import statistics
import sys

from arena.original_logs import read_original_logs
from arena.records import RaceFigures, winner_index


def column(group: list[RaceFigures], agent: str) -> str:
    """``agent``'s median finish time (finished races) and the races it had a collision in."""
    karts = [k for r in group for k in r.karts if k.agent == agent]
    times = [k.total_time for k in karts if k.total_time is not None]
    median = f"{statistics.median(times):.2f} s" if times else "-"
    hit = sum(k.collisions_at_fault > 0 for k in karts)
    return f"{agent} median {median} ({len(times)} finished), collisions in {hit}"


def main(folder: str) -> None:
    races = [
        r for r in read_original_logs(folder) if r.track == "complex" and set(r.agents) == {"mcts-lqng", "fixed-lqng"}
    ]
    for lane in (2, 3):
        for won in (True, False):
            group = []
            for race in races:
                assert race.start_lanes is not None
                m = race.agents.index("mcts-lqng")
                if race.start_lanes[m] == lane and (winner_index(race.karts) == m) == won:
                    group.append(race)
            if not group:
                continue
            label = "won" if won else "lost"
            columns = "; ".join(column(group, agent) for agent in ("mcts-lqng", "fixed-lqng"))
            print(f"mcts-lqng from lane {lane}, {label} {len(group)}: {columns}")
            if won and lane == 3:
                for race in group:
                    figures = {k.agent: k for k in race.karts}
                    m, f = figures["mcts-lqng"], figures["fixed-lqng"]
                    print(
                        f"  experiment {race.index}: mcts-lqng {m.total_time} s ({m.collisions_at_fault} collisions), "
                        f"fixed-lqng {f.total_time} s ({f.collisions_at_fault})"
                    )


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "../shared/spec/original_logs")
