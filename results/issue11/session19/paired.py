"""Paired reading of two spread-start series raced on the same seeds (``scripts/head_to_head.py --start-spread``):
kart 0 of each (e.g. mcts-lqng, and fixed-lqng as the control) against fixed-lqng, with the same launch delays and
lanes race for race. Prints kart 0's wins in each, by start lane and by which kart launched first, the races only
one of them won, and, for the lane-2 starts kart 0 launched first, the smallest launch lead each won with.

    .venv/bin/python results/issue11/session19/paired.py TACTICAL.txt CONTROL.txt
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

LINE = re.compile(r"race +(\d+) seed (\d+) lanes \((\d), (\d)\) delays ([\d.]+)/([\d.]+) winner (\S+)")


def races(path: str) -> dict[int, tuple[int, float, float, bool]]:
    """race index -> (kart 0's start lane, its launch delay, the other's, kart 0 won)."""
    found = {}
    for line in Path(path).read_text().splitlines():
        m = LINE.match(line)
        if m:
            found[int(m[1])] = (int(m[3]), float(m[5]), float(m[6]), m[7] == "0")
    return found


def main(tactical_path: str, control_path: str) -> None:
    tactical, control = races(tactical_path), races(control_path)
    common = sorted(set(tactical) & set(control))
    if any(tactical[i][:3] != control[i][:3] for i in common):
        raise SystemExit("the two series do not share their lanes and launch delays race for race")
    print(
        f"{len(common)} paired races: kart 0 wins {sum(tactical[i][3] for i in common)} (tactical) "
        f"and {sum(control[i][3] for i in common)} (control)"
    )
    print("start lane | launched first | races | tactical wins | control wins")
    for lane in (2, 3):
        for first in ("kart 0", "the other"):
            chosen = [
                i for i in common if tactical[i][0] == lane and (tactical[i][1] < tactical[i][2]) == (first == "kart 0")
            ]
            print(
                f"{lane} | {first} | {len(chosen)} | {sum(tactical[i][3] for i in chosen)} | "
                f"{sum(control[i][3] for i in chosen)}"
            )
    only_tactical = sum(tactical[i][3] and not control[i][3] for i in common)
    only_control = sum(control[i][3] and not tactical[i][3] for i in common)
    print(f"won by the tactical kart only: {only_tactical}; by the control only: {only_control}")
    for name, series in (("tactical", tactical), ("control", control)):
        leads = sorted(
            (series[i][2] - series[i][1], series[i][3])
            for i in common
            if series[i][0] == 2 and series[i][1] < series[i][2]
        )
        won = [lead for lead, w in leads if w]
        lost = [lead for lead, w in leads if not w]
        print(
            f"{name}: lane-2 starts launched first: {len(leads)}; smallest winning lead {min(won):.3f} s"
            if won
            else f"{name}: no lane-2 start won",
            end="",
        )
        print(f", largest losing lead {max(lost):.3f} s" if lost else "")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
