"""A track of your own: write a centre line in the racetrack-database CSV format, import it, race on it.

From the repo root::

    .venv/bin/python examples/03_custom_track.py                         # writes ./bean.csv and ./bean.json
    .venv/bin/python examples/03_custom_track.py --out /tmp/tracks --karts lane-follower,mcts-lqng --laps 3

The racetrack-database format (github.com/TUMFTM/racetrack-database) is one row per centre-line point:
``x_m, y_m, w_tr_right_m, w_tr_left_m`` (the distances to the right and left track edges), the circuit closing
back on its first row. :func:`sim_core.track_io.import_centreline_csv` places a checkpoint about every 10 m,
classifies each section as a straight or a curve (radius, angle, direction) and builds the walls and the 4
lanes; ``karting import-track`` is the same from the command line. The Fixed-LQNG driver computes its racing
line for the new track when the race starts. Any real circuit from that database imports
the same way (``--scale 0.1`` shrinks a Formula 1 circuit to kart size). The track file is then raced like a
built-in track: ``RaceSpec(track="path/to/track.json", ...)`` or ``karting race --track path/to/track.json``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from controllers.race import RaceSpec, run_race
from sim_core.track_io import import_centreline_csv, save_track

HALF_WIDTH = 5.0  # [m] to each edge: a 10 m road, like the paper's tracks


def write_bean_csv(path: Path, points: int = 120) -> None:
    """A bean-shaped circuit about 90 x 60 m: two long bends, one tighter hairpin and a gentle kink, anticlockwise."""
    lines = ["# x_m,y_m,w_tr_right_m,w_tr_left_m"]
    for i in range(points):
        a = 2.0 * math.pi * i / points
        radius = 34.0 + 8.0 * math.cos(2.0 * a) + 4.0 * math.sin(3.0 * a)  # [m] from the middle of the bean
        x, y = 1.3 * radius * math.cos(a), radius * math.sin(a)
        lines.append(f"{x:.3f},{y:.3f},{HALF_WIDTH},{HALF_WIDTH}")
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("."), help="folder for bean.csv and bean.json")
    parser.add_argument("--karts", default="fixed-lqng,lane-follower", help="comma-separated registered names")
    parser.add_argument("--laps", type=int, default=2)
    args = parser.parse_args()

    args.out.mkdir(parents=True, exist_ok=True)
    csv_path, track_path = args.out / "bean.csv", args.out / "bean.json"
    write_bean_csv(csv_path)
    track = import_centreline_csv(csv_path, laps=args.laps, lane_change_limit=4)
    save_track(track, track_path, include_centreline=True)
    summary = track.summary()
    print(
        f"imported {csv_path} -> {track_path}: {summary['checkpoints']} checkpoints, {summary['length_m']} m, "
        f"{summary['straights']} straights"
    )

    spec = RaceSpec(track=str(track_path), controllers=tuple(args.karts.split(",")), laps=args.laps)
    outcome = run_race(spec)
    result = outcome.result
    print(f"{track.name}: {result.duration:.2f} s of racing simulated in {outcome.wall_seconds:.2f} s")
    for kart in sorted(result.karts, key=lambda k: k.position):
        finish = f"{kart.finish_time:7.2f} s" if kart.finish_time is not None else "    DNF"
        print(
            f"  {kart.position}. kart {kart.kart + 1} {spec.controllers[kart.kart]:<14} {finish}  "
            f"laps {kart.laps_completed}, wall hits {kart.wall_hits}"
        )


if __name__ == "__main__":
    main()
