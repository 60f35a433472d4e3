"""Racing-line optimisation time per track and the optimised line's lap time against the hand-set lanes.

Both lines are timed under the same speed-profile model (paper kart, tyre wear 0.25).
Run from the repo root: ``.venv/bin/python benchmarks/racing_line.py`` (``--help``: repeats and tracks); the last
line is one JSON object.
"""

from __future__ import annotations

import argparse
import json
import time

from controllers.racing_line import compute_racing_line, handset_line
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track

REPEATS = 5


def main() -> None:
    """Time each track's optimisation; print a line per track, then the JSON summary."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=REPEATS, help="optimisations timed per track (best kept)")
    parser.add_argument("--tracks", default="oval,complex", help="tracks, comma separated")
    args = parser.parse_args()
    seconds: dict[str, float] = {}
    ratios: dict[str, float] = {}
    for name in args.tracks.split(","):
        track = get_track(name)
        compute_racing_line(track, PAPER_KART)  # warm imports (the optimisation itself is never cached here)
        times = []
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            line = compute_racing_line(track, PAPER_KART)
            times.append(time.perf_counter() - t0)
        handset = handset_line(track, PAPER_KART)
        seconds[name] = min(times)
        ratios[name] = line.lap_time / handset.lap_time
        print(
            f"{name}: {min(times) * 1000:.0f} ms (best of {args.repeats}); lap {line.lap_time:.2f} s optimised vs "
            f"{handset.lap_time:.2f} s hand-set; lanes {''.join(map(str, line.checkpoint_lanes))}"
        )
    print(
        json.dumps(
            {
                "max_seconds_per_track": round(max(seconds.values()), 4),
                "seconds_per_track": {k: round(v, 4) for k, v in seconds.items()},
                "lap_time_ratio_optimised_vs_handset": round(max(ratios.values()), 4),
                "lap_time_ratio_per_track": {k: round(v, 4) for k, v in ratios.items()},
            }
        )
    )


if __name__ == "__main__":
    main()
